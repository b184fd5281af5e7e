// Fragment planning: one camera x one view request (Yang et al. 2002,
// Section 4.1 and Figure 3).
//
// Geometry. Output pixel p = (x, y) (pixel-centre coordinates of the virtual
// view) defines the line L(p) through the eye E with direction
// D(p) = R_v^T K_v^{-1} (x, y, 1). The line meets
//  * the focal plane at F(p); camera i samples its image at the projection of
//    F(p). Because the focal surface is a plane, output pixel -> camera pixel
//    is a single 3x3 homography H_i = K_i [ (R_i E + t_i) n^T - (n.E + d) R_i ] M
//    with M = R_v^T K_v^{-1} (lens distortion is applied afterwards), and
//    H_i = K_i R_i M for the plane at infinity. With a focal surface
//    (lf/geometry/view.h: one plane per tile of the output) each tile uses its own
//    plane's homography;
//  * the camera plane at X(p) = E_2d - dist(E) * D_2d(p) / D_n(p); the aperture
//    weight of camera i is its barycentric coordinate of X(p) in the simplex
//    of the rig triangulation containing X(p) (a wider aperture, scale k:
//    (b + k - 1) / k in each simplex of camera i scaled by k about it, see
//    ViewGeometry::inside_scaled; still a ratio of linear forms). Every barycentric coordinate is
//    e_k(X(p)) / sum_j e_j(X(p)) with e_k linear on the plane, so multiplied by
//    D_n(p) it is a ratio of two linear functions of (x, y): perspective-
//    correct, and every region where a camera contributes is an intersection of
//    half-planes in output pixels. Triangles behind the eye or straddling the
//    eye plane need no special case: lines, not rays, are intersected.
//
// Exactness. Pixel membership is decided by one predicate (ViewGeometry::
// inside) evaluated in double precision: signs of the facet forms, with ties
// broken by a symbolic perturbation of X towards +s (then +t). Shared facets
// are evaluated bit-identically with opposite signs, so every line that meets
// the triangulated part of the camera plane is claimed by exactly one simplex:
// the weights at each output pixel sum to 1 wherever the view sees the camera
// surface, and are 0 elsewhere. Fragment runs are the exact pixel sets of that
// predicate (float clipping only proposes them).
//
// Degenerate cases (defined results):
//  * eye exactly on the camera plane: every line meets the plane at the eye,
//    so the weights are constant over the image (the eye's barycentrics);
//  * lines parallel to the camera plane (D_n = 0, eye off the plane): they
//    never meet the camera surface, weight 0 (not seen);
//  * eye on the focal plane: every line meets the focal plane at the eye, so
//    each camera contributes the single colour where it sees the eye;
//  * lines parallel to the focal plane meet it at infinity: cameras sample the
//    line's direction (continuous with nearby pixels);
//  * a focal point behind camera i (or in its image plane): not visible to
//    camera i, alpha 0 (renormalised by the compositor).
#pragma once

#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"

namespace lf {

// h(x, y) = a x + b y + c over output pixel coordinates.
struct PixelForm {
  double a = 0, b = 0, c = 0;
  double operator()(double x, double y) const { return a * x + b * y + c; }
  PixelForm operator*(double s) const { return {a * s, b * s, c * s}; }
  PixelForm operator+(const PixelForm& o) const { return {a + o.a, b + o.b, c + o.c}; }
};

// Weights at one output pixel.
struct ApertureSample {
  int simplex = -1;                       // -1: the line does not meet the camera surface
  int count = 0;                          // cameras in the simplex
  std::array<int, 3> cams{-1, -1, -1};    // camera indices
  std::array<double, 3> weight{0, 0, 0};  // in [0, 1], summing to 1
};

// A request's blending field (lf/geometry/view.h Aperture kUlr, kFourCamera): the weight of
// every camera at every vertex of its kUlrGrid-pixel grid. It depends on
// the whole rig, not on one camera, so cameras in one process can share it
// (ViewGeometry's `ulr` argument, gst/lffragment.cpp).
struct UlrField {
  int cols = 0, rows = 0, cameras = 0;  // cells across and down; rig cameras
  std::vector<double> w;                // per vertex (row-major), per camera
};

// Output pixels [x0, x1) x [y0, y1) focused through focal plane `plane`
// (ViewGeometry::plane).
struct FocalRegion {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0, plane = 0;
};
// What a request's focal surface tiling is for every camera alike (it
// depends on the request only, so cameras can share it: ViewGeometry's
// `layout` argument; lf::shared_geometry shares the whole geometry): per tile whether
// its second plane is the nearer (ViewGeometry::layer_plane), and each
// fragment layer's regions of one plane (ViewGeometry::regions). A request
// of 1920x1080 with 16-pixel tiles has 120 x 68 tiles; 64 cameras each
// making their own cost 63 times the shared part.
struct SurfaceLayout {
  int width = 0, height = 0;                        // the request's output size, pixels
  int cols = 0, rows = 0;                           // the surface's tiles; 0 without one
  std::vector<uint8_t> second_nearer;               // per tile, with second planes (else empty)
  std::array<std::vector<FocalRegion>, 2> regions;  // per layer
};

// Everything about one request that all cameras share.
class ViewGeometry {
 public:
  // Validates the request (throws std::invalid_argument) and precomputes.
  // With `only_camera` >= 0, only that camera's homographies are computed (a
  // random access camera needs just its own); homography(i) of any other
  // camera is then the zero matrix.
  // With `ulr` (a kUlr request's field, computed for the same rig and
  // request, e.g. by another camera's ViewGeometry: ulr_field()), the field
  // is taken instead of computed; one of another size is ignored. With
  // `layout` (computed for the same rig and request, e.g. by another
  // camera's ViewGeometry: surface_layout()) likewise.
  ViewGeometry(const Rig& rig, const ViewRequest& request, int only_camera = -1,
               std::shared_ptr<const UlrField> ulr = nullptr,
               std::shared_ptr<const SurfaceLayout> layout = nullptr);

  const Rig& rig() const { return *rig_; }
  const ViewRequest& request() const { return req_; }
  int width() const { return req_.view.width; }
  int height() const { return req_.view.height; }

  // Line-of-pixel direction in world coordinates (not normalised).
  cv::Vec3d ray(double x, double y) const { return M_ * cv::Vec3d(x, y, 1.0); }
  // Focal planes: the request's surface planes, or its one focal plane.
  int plane_count() const { return static_cast<int>(planes_.size()); }
  const FocalPlane& plane(int p) const { return planes_[p]; }
  // Plane of the tile holding output pixel (x, y) (0 without a surface).
  int plane_at(int x, int y) const {
    return req_.surface.empty() ? 0 : req_.surface.plane_at(x, y);
  }
  // Output pixel -> undistorted pixel of camera `index` through focal plane
  // `p` (homogeneous; the sign is that of the true projective point, see
  // focal_sign()).
  const cv::Matx33d& homography(int index, int p = 0) const {
    if (only_ < 0) return H_[p * ncam_ + index];
    return index == only_ ? H_[p] : kZero;
  }
  const cv::Matx33d& homography_at(int index, int x, int y) const {
    return homography(index, plane_at(x, y));
  }
  // Sign of the focal intersection's homogeneous w at a pixel (through the
  // pixel's plane): the homography images a point in front of camera i iff
  // focal_sign * z_i > 0.
  int focal_sign(int x, int y) const { return focal_sign(x, y, plane_at(x, y)); }
  int focal_sign(double x, double y, int p) const;
  bool focal_at_infinity(int p = 0) const { return planes_[p].at_infinity(); }
  // The plane of surface tile `tile` (row-major) in fragment layer `layer`
  // (plan_fragment), or -1 for none: in a tile with a second plane
  // (FocalSurface::second_of), layer 1 is the nearer of its two planes and
  // layer 0 the farther (along the ray of the tile's centre pixel; a plane
  // behind the eye, parallel to the ray or at infinity is infinitely far),
  // so that a compositor knows which occludes without the request; in
  // other tiles layer 0 is the tile's plane and layer 1 none. Without a
  // surface: plane 0 in layer 0.
  int layer_plane(int layer, int tile) const;
  // Fragment layer `layer`'s regions of one plane (layer_plane): per tile
  // row the maximal horizontal stretches of tiles that share a plane, row
  // by row (layer 1: just the two-plane tiles; empty without second
  // planes); without a surface the whole frame through plane 0 in layer 0.
  // Other layers: none.
  const std::vector<FocalRegion>& regions(int layer) const {
    return layer == 0 || layer == 1 ? layout_->regions[layer] : kNoRegions;
  }
  // The tiling (never null), to share.
  const std::shared_ptr<const SurfaceLayout>& surface_layout() const { return layout_; }

  // Exact membership of a pixel's line in simplex `s`; fills barycentric
  // weights (per simplex vertex) when inside.
  bool inside(int s, double x, double y, std::array<double, 3>* weights = nullptr) const;
  // inside(s, x, y, &w) && w[slot] > 0, with one division instead of three
  // (the planner's predicate).
  bool weight_positive(int s, int slot, double x, double y) const;
  // With the request's aperture scale k > 1 (lf/geometry/view.h Aperture): whether
  // the pixel's line meets simplex `s` scaled by k about its vertex `slot`
  // with a positive weight of that vertex's camera, and the weight,
  // (e_slot + (k - 1) sum_j e_j) / (k sum_j e_j) (the vertex's barycentric
  // coordinate b becomes (b + k - 1) / k): the facets through the vertex
  // are the simplex's own, with its tie rule, so the scaled simplices of
  // one camera tile its scaled star exactly.
  bool inside_scaled(int s, int slot, double x, double y, double* weight = nullptr) const;
  // The simplex containing the pixel's line and its weights.
  ApertureSample locate(double x, double y) const;

  // kUlr and kFourCamera (lf/geometry/view.h Aperture): the blending field. Its cells are kUlrGrid
  // output pixels square, ulr_cols() x ulr_rows() of them; cell (cx, cy)
  // holds pixels [cx G, cx G + G) x [cy G, cy G + G), split by its diagonal
  // into half 0 (u >= v, with u, v the pixel's offsets in the cell) and half
  // 1 (u < v), each holding its pixels exactly once. ulr_weight(): camera
  // `index`'s weight at vertex (vx, vy), pixel (vx G, vy G); ulr_form():
  // its weight over a half, linear in the pixel (interpolated from the
  // half's three vertices). Empty (0 cells) for the tent.
  int ulr_cols() const { return ulr_ ? ulr_->cols : 0; }
  int ulr_rows() const { return ulr_ ? ulr_->rows : 0; }
  double ulr_weight(int index, int vx, int vy) const {
    return ulr_->w[(static_cast<size_t>(vy) * (ulr_->cols + 1) + vx) * ncam_ + index];
  }
  // The blending field (null for other apertures), to share.
  const std::shared_ptr<const UlrField>& ulr_field() const { return ulr_; }
  PixelForm ulr_form(int index, int cx, int cy, int half) const;
  static bool in_ulr_half(int x, int y, int cx, int cy, int half) {
    const int u = x - cx * kUlrGrid, v = y - cy * kUlrGrid;
    return u >= 0 && v >= 0 && u < kUlrGrid && v < kUlrGrid && (half == 0 ? u >= v : u < v);
  }
  // Whether camera `index` sees the focal point of pixel (x, y).
  bool visible(int index, int x, int y) const;

  // Pixel forms (for planning).
  bool eye_on_camera_plane() const { return eye_dist_ == 0.0; }
  const PixelForm& camera_plane_denominator() const { return dn_; }
  PixelForm facet_form(int facet, int sign) const;  // e(X(p)) * D_n(p)
  double facet_at_eye(int facet, int sign) const;   // e(E_2d)
  PixelForm focal_denominator(int p = 0) const { return fw_[p]; }

 private:
  bool tie_positive(int facet, int sign) const;
  // The simplex's facet forms at the pixel's line (at the eye when it is
  // on the camera plane) and the side of the camera plane the line meets
  // (+-1); false for a line parallel to the plane.
  bool facet_values(const Simplex& sx, double x, double y, std::array<double, 3>& v,
                    double& orient) const;
  // The facet values of simplex `s` at the pixel's line and their sum, when
  // the line meets the simplex (its tie rule included); a point simplex:
  // {1, 0, 0} and 1.
  bool facet_sums(int s, double x, double y, std::array<double, 3>& v, double& sum) const;
  const Rig* rig_;
  ViewRequest req_;
  cv::Matx33d M_;
  double eye_dist_ = 0;
  cv::Vec2d eye2d_;
  PixelForm dn_;
  std::vector<PixelForm> facet_px_;
  std::vector<double> facet_eye_;
  std::vector<FocalPlane> planes_;
  std::vector<PixelForm> fw_;  // per plane
  int ncam_ = 0;
  int only_ = -1;               // only_camera
  std::vector<cv::Matx33d> H_;  // H_[p * ncam_ + camera]; H_[p] with only_camera
  inline static const cv::Matx33d kZero = cv::Matx33d::zeros();
  inline static const std::vector<FocalRegion> kNoRegions;
  std::shared_ptr<const SurfaceLayout> layout_;
  std::shared_ptr<const SurfaceLayout> compute_layout() const;
  std::shared_ptr<const UlrField> compute_ulr() const;
  std::shared_ptr<const UlrField> ulr_;
};

// A run of output pixels [x0, x1) on row y rendered with one piece.
struct Run {
  int y = 0, x0 = 0, x1 = 0;
  int piece = 0;
};

// One region of a fragment with a single weight formula and homography.
// Float coefficients are normalised copies of the double ones.
struct FragmentPiece {
  cv::Matx33d H;         // output pixel -> camera homogeneous, oriented so z > 0 where visible
  PixelForm weight_num;  // aperture weight = num / den, in [0, 1] on the piece
  PixelForm weight_den;
};

struct FragmentPlan {
  int camera_index = -1;
  int camera_id = -1;
  int out_width = 0, out_height = 0;
  cv::Rect rect;  // bounding box of the pixels with nonzero weight (empty if none)
  Sampling sampling = Sampling::kBilinear;  // the request's (lf/render/render.h)
  int layer = 0;                            // plan_fragment's layer
  std::vector<FragmentPiece> pieces;
  std::vector<Run> runs;  // sorted by (y, x0), disjoint
  // Per row of rect: [begin, end) in output x (the hull of that row's runs).
  std::vector<std::array<int, 2>> row_spans;

  bool empty() const { return runs.empty(); }
  size_t pixel_count() const;  // pixels carried (sum of row spans)
};

// Plans camera `index`'s fragment for the request. Never throws for a valid
// ViewGeometry; a camera that does not contribute gets an empty plan. With a
// focal surface, each tile is planned through its own plane (the pixel sets
// are those of the same predicates with that plane) and runs are cut at tile
// edges where the plane changes: one piece per (simplex, orientation, plane).
// Layers (a surface with two planes in some tiles, lf/geometry/view.h
// FocalSurface::second_of): layer 1 holds the camera's pixels in just those
// tiles, through the nearer of their two planes (empty when no tile has
// two); layer 0 holds every tile through its other plane
// (ViewGeometry::layer_plane). Without second planes layer 0 is the
// fragment above.
FragmentPlan plan_fragment(const ViewGeometry& geometry, int index, int layer = 0);
// Both layers of camera `index` at once (what the camera plans with when
// the request has second planes): {plan_fragment(g, index, 0),
// plan_fragment(g, index, 1)}, sharing the work that does not depend on
// the focal plane.
std::array<FragmentPlan, 2> plan_fragment_layers(const ViewGeometry& geometry, int index);

// Whether camera `index`'s plan for the geometry's request is its weighted
// pixels alone, whatever the focal plane: a single plane (no surface, no
// ULR or four-camera blending field), ahead of the eye at every output pixel
// (or at infinity), with every pixel's focal point in front of the camera.
// The aperture weights live on the camera plane, so two such geometries
// that differ only in the focal plane give the camera plans with the same
// runs and weight forms; only the homographies differ (aim_plan).
bool plan_is_plane_free(const ViewGeometry& geometry, int index);
// A plan made where plan_is_plane_free, re-aimed at `geometry`'s plane
// (plan_is_plane_free there too, same rig, eye, view and aperture): each
// piece's homography becomes this plane's, as plan_fragment would make it.
// What a sweep over planes (lf/focus/focus.h photo_consistency) plans once.
void aim_plan(const ViewGeometry& geometry, FragmentPlan& plan);

}  // namespace lf
