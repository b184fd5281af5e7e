// A focal surface estimated from the images (beyond the paper, which uses one
// focal plane per view, Yang et al. 2002, Section 4.3): each tile of the
// output view is focused on the plane where the cameras that the tent
// aperture blends there agree best ("model only what the scene needs": a
// tile leaves the view's best single plane only when another plane is
// clearly more photo-consistent there).
//
// Method: a plane sweep at low resolution, in two passes. Pass 1: `planes`
// candidate planes parallel to the camera plane, evenly spaced in inverse
// depth over a parallax of 0 .. max_parallax_px between neighbouring
// cameras; the photo-consistency (lf/focus/focus.h: aperture-weighted colour
// variance, truncated at occlusions) is measured at every pixel of an
// analysis view `analysis_width` pixels wide and summed per tile. Pass 2:
// `fine_planes` planes over the depths that pass 1 gave the tiles, at
// `fine_width`. The best single plane is the minimum of the whole view's mean
// cost (parabola-refined). Per tile, costs are aggregated over the 3 x 3
// tiles around it, and a tile label (a plane of the sweep, or the single
// plane) is chosen by semi-global matching over the tile grid (4 directions;
// a step of one plane costs step_penalty, a larger jump jump_penalty; leaving
// the single plane costs leave_penalty). Tiles that too few cameras see, or
// whose cost varies by less than min_texture over the planes (textureless),
// keep the single plane; when every tile agrees on one plane the surface is
// empty and that plane is the single plane.
//
// Second planes (SurfaceOptions::second_planes, on by default, beyond the
// paper): a tile at a depth edge takes its far neighbour's plane; a tile
// with a thin structure inside (no neighbour at its depth) takes the plane
// its cells vote for (pass 1's planes, costs per cell of about 2 x 2
// analysis pixels at fine_width), and the structure grows from tile to tile.
//
// Units: costs are variances of 8-bit grey levels (levels^2).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "lf/focus/focus.h"
#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"

namespace lf {

struct SurfaceOptions {
  int tile = 16;                  // output pixels per tile side (FocalSurface::tile)
  int analysis_width = 160;       // pass 1: analysis view width, pixels (at most the view's)
  int planes = 32;                // pass 1: candidate planes over the whole parallax range
  int fine_width = 320;           // pass 2: analysis view width
  int fine_planes = 16;           // pass 2: planes over the depths that pass 1 found
  double max_parallax_px = 24.0;  // at full camera resolution, between neighbours
  double truncate = 25.0;         // per-pixel colour standard deviation cap (8-bit levels)
  // Penalties in percent of the scene's contrast (the median over textured
  // tiles of their cost's range over the planes), so that they mean the
  // same on a low-contrast scene as on a high-contrast one.
  double step_penalty = 4.0;   // neighbouring tiles one plane apart
  double jump_penalty = 40.0;  // neighbouring tiles further apart
  double leave_penalty = 2.0;  // a tile off the single plane
  // Each tile's costs are the mean over the 3 x 3 tiles around it; a
  // neighbour whose own cheapest plane is more than edge_gap planes from the
  // tile's counts edge_weight there (1: the plain mean), so a depth does not
  // bleed across a depth edge (docs/rendering.md: +0.15 dB on Chess's
  // in-between views, tuned on its leave-one-out views).
  int edge_gap = 2;           // planes, >= 0
  double edge_weight = 0.25;  // 0..1
  double min_texture = 2.0;   // cost range (levels^2) below which a tile keeps the single plane
  // Between the fine planes: a tile's depth moves from its plane by the
  // vertex of the parabola through its (aggregated) costs at the planes
  // either side, rounded to 1/sub_steps of a plane step. 1 (the default):
  // the planes only. 3 gains 0.02-0.09 dB on the in-between views but costs
  // the live pipeline about a fifth more CPU per frame (each tile off its plane
  // cuts the runs of tiles that share one; docs/rendering.md), so it is for
  // offline renders. 1..8.
  int sub_steps = 1;
  // For estimate() with a SurfaceCosts carried between frames: each call
  // evaluates every stride-th candidate plane (a different phase each call)
  // and reuses the other planes' costs from earlier calls.
  int stride = 1;
  // Two planes per tile: a textured tile next to a depth edge (a neighbour
  // labelled second_gap planes of the first pass or more from its own) gets
  // the furthest such neighbour's plane as its second
  // (FocalSurface::second_of; each camera then sends those tiles twice and
  // the compositor chooses per pixel, lf/render/composite.h LayerCompositor).
  bool second_planes = true;
  double second_gap = 4.0;
  // ... and any other tile that holds a thin structure (bars, wires: no
  // neighbour labelled at its depth) gets the structure's plane: pass 1's
  // planes (the whole range of depths) are also swept at fine_width, their
  // costs summed per cell of about 2 x 2 analysis pixels (thin_cell). A cell votes for its best
  // plane when that plane is second_gap planes of the first pass or more from the tile's, costs at
  // most thin_ratio of the tile's plane there, and is lower by at least thin_margin percent of the
  // scene's contrast (as the penalties). The plane with the most votes (a plane and its two
  // neighbours counted together) is the tile's candidate when at least thin_fraction of its cells,
  // and at least 2, voted for it; it becomes the second plane when at least thin_neighbours of the
  // 8 neighbouring tiles have a candidate within a plane of it (a structure runs on through its
  // neighbours; a lone candidate is noise: on Chess at 640x480 every one was, and cost up to 1 dB).
  // From the tiles so found the structure grows into every neighbouring tile (8-connected, on and
  // on) where at least thin_grow_votes cells voted within a plane of it: a grating's narrow bars
  // leave many tiles a few votes short (tests/test_surface.cpp ThinStructures...: see
  // docs/rendering.md for what it gains; one vote was enough for the bars, but found false
  // structures on the Blender shop). A textured plane or a slope has cells whose best plane is the
  // tile's or near it: no votes. The cells' costs are measured at
  // fine_width, where a thin structure is wider in analysis pixels. With thin_spread, the tiles
  // so found then give the structure's plane to each of their 4 neighbours that has no second
  // plane (once, not on and on): a bar on a tile border leaves the tile beside it a pixel or two
  // of the bar, too few votes (docs/rendering.md: +0.4 dB on thin structures, 1.06x the fragment
  // pixels; the compositor's per-pixel choice keeps the tile's own plane where the bar is not).
  double thin_ratio = 0.5;     // 0 < thin_ratio <= 1
  double thin_margin = 10.0;   // percent of the contrast, >= 0
  double thin_fraction = 0.2;  // of the tile's cells, 0..1
  int thin_neighbours = 2;     // of 8 neighbouring tiles, 0..8
  int thin_grow_votes = 2;     // >= 1
  bool thin_spread = true;
  // Hysteresis between estimates of one view (a SurfacePrior: a live
  // stream re-estimates the surface every few frames): a tile keeps the
  // inverse depth it had unless its new plane is cheaper by more than
  // change_penalty percent of the scene's contrast (as the penalties), and
  // the single plane likewise by the percent of its whole-view cost curve's
  // range; so sensor noise does not switch a tile between two planes of
  // nearly equal cost from frame to frame (flicker). 0: off.
  double change_penalty = 4.0;
};

// The previous estimate of the same view (cols x rows tiles), for
// SurfaceOptions::change_penalty. Empty (no tiles): none.
struct SurfacePrior {
  int cols = 0, rows = 0;
  double single_q = 0;         // the single plane's inverse depth
  std::vector<double> tile_q;  // per tile, row-major (SurfaceEstimate::tile_q)
  bool fits(int c, int r) const {
    return c == cols && r == rows && tile_q.size() == static_cast<size_t>(c) * r;
  }
};

// Per-tile costs of one sweep.
struct SweepCosts {
  std::vector<double> qs;          // inverse depths of the planes
  std::vector<double> sum, count;  // [plane * tiles + tile]
  std::vector<bool> have;          // per plane: evaluated at least once
  // Per cell of `cell` output pixels (0: none; pass 1 and surface probes
  // with second planes): cell_cols x cell_rows cells, [plane * cells + cell].
  int cell = 0, cell_cols = 0, cell_rows = 0;
  std::vector<double> cell_sum, cell_count;
};
// Per-tile costs carried from one frame's estimate to the next (one viewer).
struct SurfaceCosts {
  int cols = 0, rows = 0, width = 0, height = 0;
  SweepCosts coarse, fine;
  SweepCosts cells;  // with second planes: pass 1's planes per cell, at fine_width
  int phase = 0;
  SurfacePrior prior;  // the last estimate (hysteresis)
};

struct SurfaceEstimate;
// The prior that estimate `e` of a cols x rows grid leaves for the next.
SurfacePrior prior_of(const SurfaceEstimate& e, int cols, int rows);

struct SurfaceEstimate {
  // The request's focal plane is `single`; `surface` is empty when every
  // tile keeps it (a flat scene needs one plane).
  FocalPlane single;
  double single_q = 0;         // inverse depth of `single`, rig units^-1
  FocalSurface surface;        // tiles of SurfaceOptions::tile
  std::vector<double> tile_q;  // inverse depth per tile (rows * cols)
  std::vector<bool> textured;  // per tile: decided by the images (not a fallback)
  int planes_used = 1;         // distinct planes over the tiles (first and second)
  int two_plane_tiles = 0;     // tiles with a second plane (SurfaceOptions::second_planes)
  int thin_tiles = 0;          // of those, given one for a thin structure inside the tile
  int planes_evaluated = 0;    // candidate planes swept by this call (pass 1's twice
                               // with second planes: per tile, and per cell at fine_width)
  int kept_tiles = 0;          // labelled tiles that kept the prior's depth (hysteresis)
};

// Throws std::invalid_argument naming the first bad option.
void validate(const SurfaceOptions& opt);
// The first pass's largest inverse depth (rig units^-1): max_parallax_px
// between neighbouring cameras (Rig::typical_spacing) at the cameras'
// median focal length; candidate plane k is at q_max * k / (planes - 1).
// Throws std::invalid_argument for an empty rig.
double sweep_q_max(const Rig& rig, const SurfaceOptions& opt);

// The side (output pixels) of the cells whose costs vote for thin
// structures (SurfaceOptions::thin_ratio): a power-of-two fraction of `tile`
// about 2 analysis pixels wide, for an analysis `analysis_width` pixels
// wide of a view `width` wide; `tile` itself when a tile has under 4.
int thin_cell(int tile, int analysis_width, int width);
// The bin of `bin` output pixels that each of `samples` analysis pixels
// across an output `extent` pixels long falls in (its centre, clamped to the
// last bin): the tiles or cells of an analysis view's columns or rows.
std::vector<int> analysis_bins(int samples, int extent, int bin);

class FocalSurfaceEstimator {
 public:
  // `images`: CV_8UC4, one per rig camera. Throws std::invalid_argument on a
  // count mismatch or bad options.
  FocalSurfaceEstimator(const Rig& rig, const std::vector<cv::Mat>& images,
                        SurfaceOptions opt = {});
  // The surface for `req` (its focal plane and surface are ignored). With
  // `carry`, planes are evaluated stride-wise and costs kept across calls,
  // and the last estimate is the next one's prior (hysteresis,
  // SurfaceOptions::change_penalty); a carry of another view size starts
  // afresh.
  SurfaceEstimate estimate(const ViewRequest& req, SurfaceCosts* carry = nullptr) const;
  double candidate_q(int k) const { return q_max_ * k / (opt_.planes - 1); }
  const SurfaceOptions& options() const { return opt_; }

 private:
  const Rig* rig_;
  SurfaceOptions opt_;
  double q_max_ = 0;
  AnalysisImages coarse_, fine_;
};

// The surface from per-tile costs of one sweep, as the estimator's last
// pass: `c.qs` holds at least 3 inverse depths in increasing order, and
// c.sum / c.count the cost sums and sample counts per plane and tile of a
// cols x rows grid of opt.tile pixels ([plane * tiles + tile]); the single
// plane is at inverse depth `single_q` (NaN: the minimum of the whole
// view's mean cost, parabola-refined). Tiles whose 3 x 3 neighbourhood has
// fewer than `min_count` samples at some plane, or too little texture, keep
// the single plane; the others are labelled by semi-global matching. With
// opt.second_planes, tiles at depth edges get second planes, and so do
// tiles with thin structures when `cells` has per-cell costs (cells->cell > 0,
// a whole fraction of opt.tile, cell_cols x cell_rows cells covering the
// tiles' grid; its planes may differ from c's). Used
// by FocalSurfaceEstimator and by surface probes (lf/focus/surface_probe.h), which
// measure the costs from the cameras' fragments. With a `prior` of this
// grid and opt.change_penalty > 0, tiles and the single plane keep its
// inverse depths unless clearly worse (hysteresis; a kept depth adds a
// plane only while the surface has fewer than FocalSurface::kMaxPlanes).
// planes_evaluated is left 0. Throws std::invalid_argument if the costs do
// not fit the grid.
SurfaceEstimate surface_from_costs(const Rig& rig, const SweepCosts& c, int cols, int rows,
                                   double single_q, double min_count, const SurfaceOptions& opt,
                                   const SweepCosts* cells = nullptr,
                                   const SurfacePrior* prior = nullptr);

// Applies an estimate to a request: its focal plane and surface.
void apply(const SurfaceEstimate& e, ViewRequest& req);

// An estimate against a ground-truth disparity map of its view, in the HCI
// benchmark's convention (Honauer et al., ACCV 2016; lf/io/datasets.h): d
// pixels of shift per camera step of `baseline` rig units, d = -a *
// baseline with a the rig's light-slab focal parameter. Per tile of `tile`
// pixels that `e` marks textured: |d at the inverse depth `tile_q[t]` - the
// median ground truth over the tile (clipped to the map)|, in pixels,
// sorted ascending. `tile_q` is e.tile_q for the surface, or one inverse
// depth repeated for a single plane. Throws std::invalid_argument if `gt` is
// not CV_32FC1, `tile_q` or e.textured do not have one entry per tile of
// `gt`, or the rig has no focal parameter.
std::vector<double> tile_disparity_errors(const Rig& rig, const SurfaceEstimate& e,
                                          const std::vector<double>& tile_q, const cv::Mat& gt,
                                          int tile, double baseline);

}  // namespace lf
