#include "lf/focus/focal_surface.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace lf {

void validate(const SurfaceOptions& opt) {
  auto bad = [](const std::string& what) {
    throw std::invalid_argument("focal surface estimator: " + what);
  };
  if (opt.tile < FocalSurface::kMinTile || opt.tile > FocalSurface::kMaxTile)
    bad("tile " + std::to_string(opt.tile) + " is outside " +
        std::to_string(FocalSurface::kMinTile) + ".." + std::to_string(FocalSurface::kMaxTile));
  if (opt.planes < 3 || opt.planes >= FocalSurface::kMaxPlanes)
    bad("planes must be 3.." + std::to_string(FocalSurface::kMaxPlanes - 1));
  if (opt.analysis_width < 16 || opt.fine_width < 16) bad("analysis width below 16 pixels");
  if (opt.fine_planes < 3 || opt.fine_planes >= FocalSurface::kMaxPlanes)
    bad("fine planes must be 3.." + std::to_string(FocalSurface::kMaxPlanes - 1));
  if (opt.stride < 1 || opt.stride > std::min(opt.planes, opt.fine_planes))
    bad("stride must be 1..planes");
  if (!(opt.max_parallax_px > 0) || !(opt.truncate > 0)) bad("parallax and truncation must be > 0");
  if (!(opt.thin_ratio > 0 && opt.thin_ratio <= 1) || !(opt.thin_margin >= 0) ||
      !(opt.thin_fraction >= 0 && opt.thin_fraction <= 1) || opt.thin_neighbours < 0 ||
      opt.thin_neighbours > 8 || opt.thin_grow_votes < 1)
    bad("thin structure votes: ratio 0..1, margin >= 0, fraction 0..1, neighbours 0..8, grow "
        "votes >= 1");
  if (!(opt.change_penalty >= 0)) bad("change penalty must be >= 0");
  if (opt.sub_steps < 1 || opt.sub_steps > 8) bad("sub-steps must be 1..8");
  if (opt.edge_gap < 0 || !(opt.edge_weight >= 0 && opt.edge_weight <= 1))
    bad("edge-aware aggregation: gap >= 0, weight 0..1");
}

SurfacePrior prior_of(const SurfaceEstimate& e, int cols, int rows) {
  SurfacePrior p;
  p.cols = cols, p.rows = rows, p.single_q = e.single_q, p.tile_q = e.tile_q;
  if (!p.fits(cols, rows)) p = SurfacePrior{};
  return p;
}

std::vector<int> analysis_bins(int samples, int extent, int bin) {
  if (samples <= 0 || bin <= 0) return {};
  std::vector<int> out(samples);
  const int last = (extent + bin - 1) / bin - 1;
  for (int i = 0; i < samples; ++i)
    out[i] = std::min(last, static_cast<int>((i + 0.5) * extent / samples) / bin);
  return out;
}

int thin_cell(int tile, int analysis_width, int width) {
  const int samples = tile * analysis_width / std::max(1, width);  // analysis pixels per tile side
  int per = 1;
  while (per * 2 <= samples / 2 && tile % (per * 2) == 0) per *= 2;
  return tile / per;
}

double sweep_q_max(const Rig& rig, const SurfaceOptions& opt) {
  std::vector<double> f;
  for (const Camera& c : rig.cameras) f.push_back(c.intrinsics.fx);
  if (f.empty()) throw std::invalid_argument("focal surface estimator: empty rig");
  std::nth_element(f.begin(), f.begin() + f.size() / 2, f.end());
  return opt.max_parallax_px / (f[f.size() / 2] * rig.typical_spacing());
}

FocalSurfaceEstimator::FocalSurfaceEstimator(const Rig& rig, const std::vector<cv::Mat>& images,
                                             SurfaceOptions opt)
    : rig_(&rig), opt_(opt) {
  validate(opt);
  q_max_ = sweep_q_max(rig, opt);
  coarse_ = analysis_images(rig, images, opt.analysis_width);
  fine_ = analysis_images(rig, images, opt.fine_width);
}

namespace {

// Per-tile photo-consistency of a list of planes, kept between frames.
void sweep(const AnalysisImages& an, const ViewRequest& req, int W, int H, int T, double truncate,
           int stride, int phase, SweepCosts& c, int* evaluated) {
  const int aw = std::min(an.width, W);
  const ViewRequest sreq = scaled_request(req, aw);
  const int ah = sreq.view.height;
  const int cols = (W + T - 1) / T, rows = (H + T - 1) / T, tiles = cols * rows;
  const int n = static_cast<int>(c.qs.size());
  const int C = c.cell, ccols = C ? (W + C - 1) / C : 0, crows = C ? (H + C - 1) / C : 0;
  const size_t cells = static_cast<size_t>(ccols) * crows;
  if (c.sum.size() != static_cast<size_t>(n) * tiles || c.cell_cols != ccols ||
      c.cell_rows != crows) {
    c.sum.assign(static_cast<size_t>(n) * tiles, 0.0);
    c.count.assign(c.sum.size(), 0.0);
    c.have.assign(n, false);
    c.cell_cols = ccols, c.cell_rows = crows;
    c.cell_sum.assign(n * cells, 0.0);
    c.cell_count.assign(c.cell_sum.size(), 0.0);
  }
  // Tile (and cell) of each analysis column and row.
  const std::vector<int> tx = analysis_bins(aw, W, T), ty = analysis_bins(ah, H, T);
  const std::vector<int> cx = analysis_bins(C ? aw : 0, W, C), cy = analysis_bins(C ? ah : 0, H, C);
  cv::Mat cost;
  ConsistencyPlans plans;  // each camera planned once for all the planes
  for (int k = 0; k < n; ++k) {
    if (c.have[k] && k % stride != phase) continue;
    photo_consistency(an.rig, an.gray, sreq, c.qs[k], truncate, cost, &plans);
    double* sum = &c.sum[static_cast<size_t>(k) * tiles];
    double* cnt = &c.count[static_cast<size_t>(k) * tiles];
    std::fill(sum, sum + tiles, 0.0);
    std::fill(cnt, cnt + tiles, 0.0);
    double* csum = C ? &c.cell_sum[k * cells] : nullptr;
    double* ccnt = C ? &c.cell_count[k * cells] : nullptr;
    if (C) std::fill(csum, csum + cells, 0.0), std::fill(ccnt, ccnt + cells, 0.0);
    for (int y = 0; y < ah; ++y) {
      const float* row = cost.ptr<float>(y);
      for (int x = 0; x < aw; ++x) {
        if (row[x] < 0) continue;
        const int t = ty[y] * cols + tx[x];
        sum[t] += row[x];
        cnt[t] += 1.0;
        if (C) {
          const size_t i = static_cast<size_t>(cy[y]) * ccols + cx[x];
          csum[i] += row[x];
          ccnt[i] += 1.0;
        }
      }
    }
    c.have[k] = true;
    ++*evaluated;
  }
}

// The whole view's mean cost per plane (`fallback` where nothing was seen).
std::vector<double> global_costs(const SweepCosts& c, int tiles, double fallback) {
  const int n = static_cast<int>(c.qs.size());
  std::vector<double> global(n);
  for (int k = 0; k < n; ++k) {
    double s = 0, m = 0;
    for (int t = 0; t < tiles; ++t) s += c.sum[k * tiles + t], m += c.count[k * tiles + t];
    global[k] = m > 0 ? s / m : fallback;
  }
  return global;
}

// Minimum of the whole view's mean cost, parabola-refined: a fractional
// index into c.qs.
double best_single(const SweepCosts& c, int tiles, double fallback) {
  return refined_minimum(global_costs(c, tiles, fallback));
}

// Each tile's own cheapest plane (-1 where some plane saw none of it):
// where two neighbours' differ, a depth edge runs between them.
std::vector<int> own_best(const SweepCosts& c, int tiles) {
  const int n = static_cast<int>(c.qs.size());
  std::vector<int> own(tiles, -1);
  for (int t = 0; t < tiles; ++t) {
    double best = std::numeric_limits<double>::infinity();
    for (int k = 0; k < n; ++k) {
      const double m = c.count[static_cast<size_t>(k) * tiles + t];
      if (!(m > 0)) {
        own[t] = -1;
        break;
      }
      const double v = c.sum[static_cast<size_t>(k) * tiles + t] / m;
      if (v < best) best = v, own[t] = k;
    }
  }
  return own;
}

// The mean cost of plane k over the 3 x 3 tiles around tile (r, q), and
// its sample count in `m` (solve()'s aggregation). A neighbour whose own
// cheapest plane is more than o.edge_gap planes from the tile's counts
// o.edge_weight: the aggregation does not carry a depth across an edge.
double neighbourhood_cost(const SweepCosts& c, int cols, int rows, int r, int q, int k,
                          const std::vector<int>& own, const SurfaceOptions& o, double* m) {
  const int tiles = cols * rows, t = r * cols + q;
  double s = 0;
  *m = 0;
  for (int dr = -1; dr <= 1; ++dr)
    for (int dq = -1; dq <= 1; ++dq) {
      const int rr = r + dr, qq = q + dq, u = rr * cols + qq;
      if (rr < 0 || qq < 0 || rr >= rows || qq >= cols) continue;
      const double w =
          u != t && own[t] >= 0 && own[u] >= 0 && std::abs(own[u] - own[t]) > o.edge_gap
              ? o.edge_weight
              : 1.0;
      s += w * c.sum[static_cast<size_t>(k) * tiles + u];
      *m += w * c.count[static_cast<size_t>(k) * tiles + u];
    }
  return *m > 0 ? s / *m : 0.0;
}

// Per-plane values `v` over the increasing inverse depths `qs`, linearly
// interpolated at q; NaN outside their range.
double interpolate_at(const std::vector<double>& qs, const std::vector<double>& v, double q) {
  if (!(q >= qs.front() && q <= qs.back())) return std::numeric_limits<double>::quiet_NaN();
  size_t k = 0;
  while (k + 2 < qs.size() && q > qs[k + 1]) ++k;
  const double a = (q - qs[k]) / (qs[k + 1] - qs[k]);
  return v[k] + a * (v[k + 1] - v[k]);
}

double q_at(const std::vector<double>& qs, double pos) {
  const int k = std::min(static_cast<int>(pos), static_cast<int>(qs.size()) - 2);
  return qs[k] + (pos - k) * (qs[k + 1] - qs[k]);
}

// Tile labels by semi-global matching: 0..n-1 the sweep's planes, n the
// single plane at fractional index `gpos`; -1 for tiles without texture.
std::vector<int> solve(const SweepCosts& c, int cols, int rows, double gpos, double min_count,
                       const SurfaceOptions& o, std::vector<bool>& textured,
                       double* contrast = nullptr) {
  const int n = static_cast<int>(c.qs.size()), L = n + 1, tiles = cols * rows;
  std::vector<double> unary(static_cast<size_t>(tiles) * L, 0.0);
  textured.assign(tiles, false);
  std::vector<double> agg(n), range;
  const std::vector<int> own = own_best(c, tiles);
  for (int r = 0; r < rows; ++r)
    for (int q = 0; q < cols; ++q) {
      const int t = r * cols + q;
      bool seen = true;
      for (int k = 0; k < n && seen; ++k) {
        double m = 0;
        agg[k] = neighbourhood_cost(c, cols, rows, r, q, k, own, o, &m);
        if (m < min_count) seen = false;
      }
      if (!seen) continue;  // no information: neighbours decide, the tile keeps the single plane
      const auto [lo, hi] = std::minmax_element(agg.begin(), agg.end());
      if (*hi - *lo < o.min_texture) continue;
      textured[t] = true;
      double* u = &unary[static_cast<size_t>(t) * L];
      std::copy(agg.begin(), agg.end(), u);
      range.push_back(*hi - *lo);
      // The single plane costs what the nearer of its two bracketing planes does.
      const int g0 = std::min(static_cast<int>(gpos), n - 2);
      u[n] = gpos - g0 < 0.5 ? agg[g0] : agg[g0 + 1];
    }
  // Penalties scale with the scene's contrast: the median over textured
  // tiles of their cost's range over the planes.
  double scale = 0;
  if (!range.empty()) {
    std::nth_element(range.begin(), range.begin() + range.size() / 2, range.end());
    scale = range[range.size() / 2] / 100.0;
  }
  if (contrast) *contrast = scale;
  for (int t = 0; t < tiles; ++t)
    if (textured[t])
      for (int k = 0; k < n; ++k) unary[static_cast<size_t>(t) * L + k] += o.leave_penalty * scale;
  auto pos = [&](int l) { return l == n ? gpos : static_cast<double>(l); };
  std::vector<double> pen(static_cast<size_t>(L) * L);
  // Each label's labels one step away (a plane either side; the single
  // plane and the planes within a step of it).
  std::vector<std::vector<int>> near(L);
  for (int a = 0; a < L; ++a)
    for (int b = 0; b < L; ++b) {
      const double d = std::abs(pos(a) - pos(b));
      pen[a * L + b] = a == b ? 0.0 : (d <= 1.0 ? o.step_penalty : o.jump_penalty) * scale;
      if (a != b && d <= 1.0) near[a].push_back(b);
    }
  // The transition min_b prev[b] + pen(a, b) in O(L) per tile (semi-global
  // matching's usual form): prev[a], a step from a neighbour, or a jump
  // from the cheapest. Exactly the full minimum when a step costs no more
  // than a jump (a jump from a label a step away or from a itself is then
  // never the cheaper); otherwise the full minimum over every b.
  const double step = o.step_penalty * scale, jump = o.jump_penalty * scale;
  const bool fast = step <= jump;
  std::vector<double> total(unary.size(), 0.0), path(unary.size());
  const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (const auto& dir : dirs) {
    const int dq = dir[0], dr = dir[1];
    // Visit tiles so that the predecessor (r - dr, q - dq) comes first.
    for (int ri = 0; ri < rows; ++ri)
      for (int qi = 0; qi < cols; ++qi) {
        const int r = dr < 0 ? rows - 1 - ri : ri, q = dq < 0 ? cols - 1 - qi : qi;
        const int t = r * cols + q;
        const int pr = r - dr, pq = q - dq;
        double* cur = &path[static_cast<size_t>(t) * L];
        const double* u = &unary[static_cast<size_t>(t) * L];
        if (pr < 0 || pq < 0 || pr >= rows || pq >= cols) {
          std::copy(u, u + L, cur);
        } else {
          const double* prev = &path[static_cast<size_t>(pr * cols + pq) * L];
          const double pmin = *std::min_element(prev, prev + L);
          for (int a = 0; a < L; ++a) {
            double best = std::numeric_limits<double>::infinity();
            if (fast) {
              best = std::min(prev[a] + 0.0, pmin + jump);  // + 0.0: pen(a, a), as below
              for (const int b : near[a]) best = std::min(best, prev[b] + step);
            } else {
              for (int b = 0; b < L; ++b) best = std::min(best, prev[b] + pen[a * L + b]);
            }
            cur[a] = u[a] + best - pmin;
          }
        }
        for (int a = 0; a < L; ++a) total[static_cast<size_t>(t) * L + a] += cur[a];
      }
  }
  std::vector<int> label(tiles, -1);
  for (int t = 0; t < tiles; ++t) {
    if (!textured[t]) continue;
    const double* s = &total[static_cast<size_t>(t) * L];
    label[t] = static_cast<int>(std::min_element(s, s + L) - s);
  }
  return label;
}

// SurfaceOptions::sub_steps: each labelled tile's depth moves from its
// plane by the vertex of the parabola through its neighbourhood costs at
// the planes either side (at most half a step), rounded to 1/sub_steps of
// a step, half away from zero; tiles of one label and offset share a plane.
// The tile keeps its plane where the costs are not convex there, the
// vertex rounds to it, or the palette is nearly full (8 kept for the
// second planes).
void refine_between_planes(const Rig& rig, const SweepCosts& c, int cols, int rows,
                           const std::vector<int>& label, const SurfaceOptions& opt,
                           FocalSurface* fs, std::vector<double>* tile_q) {
  const int M = static_cast<int>(c.qs.size()), S = opt.sub_steps;
  const std::vector<int> own = own_best(c, cols * rows);
  // (label, offset) -> plane
  std::vector<int> plane_of_step(static_cast<size_t>(M) * (2 * S + 1), -1);
  for (int r = 0; r < rows; ++r)
    for (int q = 0; q < cols; ++q) {
      const int t = r * cols + q, l = label[t];
      if (l <= 0 || l >= M - 1) continue;  // the single plane (M), the range's ends, untextured
      double m = 0;
      const double a = neighbourhood_cost(c, cols, rows, r, q, l - 1, own, opt, &m),
                   b = neighbourhood_cost(c, cols, rows, r, q, l, own, opt, &m),
                   d = neighbourhood_cost(c, cols, rows, r, q, l + 1, own, opt, &m);
      const double curvature = a - 2 * b + d;
      if (!(curvature > 0)) continue;
      const double vertex = std::clamp((a - d) / (2 * curvature), -0.5, 0.5);
      const int off = static_cast<int>(std::lround(vertex * S));
      if (off == 0) continue;
      int& plane = plane_of_step[static_cast<size_t>(l) * (2 * S + 1) + off + S];
      const double pos = l + static_cast<double>(off) / S;
      if (plane < 0 && fs->planes.size() + 8 < static_cast<size_t>(FocalSurface::kMaxPlanes)) {
        plane = static_cast<int>(fs->planes.size());
        fs->planes.push_back(plane_at_inverse_depth(rig, q_at(c.qs, pos)));
      }
      if (plane < 0) continue;
      fs->plane_of[t] = static_cast<uint8_t>(plane);
      (*tile_q)[t] = q_at(c.qs, pos);
    }
}

}  // namespace

SurfaceEstimate FocalSurfaceEstimator::estimate(const ViewRequest& req, SurfaceCosts* carry) const {
  validate(req);
  const int W = req.view.width, H = req.view.height, T = opt_.tile, N = opt_.planes;
  const int cols = (W + T - 1) / T, rows = (H + T - 1) / T, tiles = cols * rows;
  SurfaceCosts local;
  SurfaceCosts& c = carry ? *carry : local;
  if (c.cols != cols || c.rows != rows || c.width != W || c.height != H ||
      c.coarse.qs.size() != static_cast<size_t>(N)) {
    c = SurfaceCosts{};
    c.cols = cols, c.rows = rows, c.width = W, c.height = H;
    for (int k = 0; k < N; ++k) c.coarse.qs.push_back(candidate_q(k));
  }
  SurfaceEstimate out;
  const double cap = opt_.truncate * opt_.truncate;
  auto min_count = [&](const AnalysisImages& an) {
    const double aw = std::min(an.width, W);
    return 0.5 * aw * (aw * H / W) / tiles;
  };

  // Pass 1: the whole range of depths, coarsely. With second planes, the
  // same planes also per cell of about 2 x 2 analysis pixels (a whole
  // fraction of a tile) at pass 2's resolution, where a thin structure is
  // wider in analysis pixels (at pass 1's, a repeated texture aliases less:
  // its labels stay there).
  if (c.coarse.cell != 0) {
    SweepCosts fresh;
    fresh.qs = c.coarse.qs;
    c.coarse = std::move(fresh);
  }
  sweep(coarse_, req, W, H, T, opt_.truncate, opt_.stride, c.phase, c.coarse,
        &out.planes_evaluated);
  const int cell = opt_.second_planes ? thin_cell(T, std::min(fine_.width, W), W) : 0;
  if (c.cells.cell != cell || c.cells.qs != c.coarse.qs) {
    SweepCosts fresh;
    fresh.qs = c.coarse.qs;
    fresh.cell = cell;
    c.cells = std::move(fresh);
  }
  if (cell)
    sweep(fine_, req, W, H, T, opt_.truncate, opt_.stride, c.phase, c.cells, &out.planes_evaluated);
  double gpos = best_single(c.coarse, tiles, cap);
  out.single_q = q_at(c.coarse.qs, gpos);
  std::vector<bool> textured;
  const std::vector<int> coarse =
      solve(c.coarse, cols, rows, gpos, min_count(coarse_), opt_, textured);

  // Pass 2: finer planes over the depths that the textured tiles chose (2nd
  // to 98th percentile, a coarse step beyond), at a higher resolution.
  std::vector<double> chosen{out.single_q};
  for (int t = 0; t < tiles; ++t)
    if (coarse[t] >= 0) chosen.push_back(coarse[t] == N ? out.single_q : c.coarse.qs[coarse[t]]);
  std::sort(chosen.begin(), chosen.end());
  const double step = candidate_q(1);
  const double qa = std::max(0.0, std::min(out.single_q, chosen[chosen.size() / 50]) - step);
  const double qb = std::max(out.single_q, chosen[chosen.size() - 1 - chosen.size() / 50]) + step;
  std::vector<double> fine_qs(opt_.fine_planes);
  for (int k = 0; k < opt_.fine_planes; ++k)
    fine_qs[k] = qa + (qb - qa) * k / (opt_.fine_planes - 1);
  if (fine_qs != c.fine.qs) {
    c.fine = SweepCosts{};
    c.fine.qs = fine_qs;
  }
  sweep(fine_, req, W, H, T, opt_.truncate, opt_.stride, c.phase, c.fine, &out.planes_evaluated);
  c.phase = (c.phase + 1) % opt_.stride;
  const double fpos = best_single(c.fine, tiles, cap);
  if (fpos > 0 && fpos < opt_.fine_planes - 1) out.single_q = q_at(fine_qs, fpos);
  const int evaluated = out.planes_evaluated;
  out = surface_from_costs(*rig_, c.fine, cols, rows, out.single_q, min_count(fine_), opt_,
                           cell ? &c.cells : nullptr, carry ? &c.prior : nullptr);
  out.planes_evaluated = evaluated;
  if (carry) c.prior = prior_of(out, cols, rows);
  return out;
}

SurfaceEstimate surface_from_costs(const Rig& rig, const SweepCosts& c, int cols, int rows,
                                   double single_q, double min_count, const SurfaceOptions& opt,
                                   const SweepCosts* cells, const SurfacePrior* prior) {
  const int tiles = cols * rows, M = static_cast<int>(c.qs.size());
  if (M < 3 || c.sum.size() != static_cast<size_t>(M) * tiles || c.count.size() != c.sum.size())
    throw std::invalid_argument("surface_from_costs: " + std::to_string(c.sum.size()) +
                                " costs for " + std::to_string(M) + " planes of " +
                                std::to_string(tiles) + " tiles");
  SurfaceEstimate out;
  if (std::isnan(single_q))
    single_q = q_at(c.qs, best_single(c, tiles, opt.truncate * opt.truncate));
  // Hysteresis: the prior's single plane holds unless the new one is
  // cheaper over the whole view by more than change_penalty percent of the
  // cost curve's range.
  const bool hysteresis = prior && opt.change_penalty > 0 && prior->fits(cols, rows);
  if (hysteresis && std::isfinite(prior->single_q) && prior->single_q != single_q) {
    const std::vector<double> g = global_costs(c, tiles, opt.truncate * opt.truncate);
    const auto [lo, hi] = std::minmax_element(g.begin(), g.end());
    const double was = interpolate_at(c.qs, g, prior->single_q),
                 now = interpolate_at(c.qs, g, single_q);
    if (was <= now + opt.change_penalty / 100.0 * (*hi - *lo)) single_q = prior->single_q;
  }
  out.single_q = single_q;
  // Its fractional index into c.qs (the inverse of q_at; c.qs need not be
  // evenly spaced, as when a probe lacks some planes).
  int k = 0;
  while (k + 2 < M && single_q > c.qs[k + 1]) ++k;
  const double gpos = k + (single_q - c.qs[k]) / (c.qs[k + 1] - c.qs[k]);
  out.single = plane_at_inverse_depth(rig, single_q);
  double scale = 0;
  const std::vector<int> label = solve(c, cols, rows, gpos, min_count, opt, out.textured, &scale);

  // Labels -> planes (index 0: the single plane).
  std::vector<int> plane_of_label(M + 1, -1);
  FocalSurface fs;
  fs.tile = opt.tile, fs.cols = cols, fs.rows = rows;
  fs.planes.push_back(out.single);
  plane_of_label[M] = 0;
  fs.plane_of.assign(tiles, 0);
  out.tile_q.assign(tiles, out.single_q);
  for (int t = 0; t < tiles; ++t) {
    const int l = label[t];
    if (l < 0) continue;
    if (plane_of_label[l] < 0) {
      plane_of_label[l] = static_cast<int>(fs.planes.size());
      fs.planes.push_back(plane_at_inverse_depth(rig, c.qs[l]));
    }
    fs.plane_of[t] = static_cast<uint8_t>(plane_of_label[l]);
    out.tile_q[t] = l == M ? out.single_q : c.qs[l];
  }
  if (opt.sub_steps > 1) refine_between_planes(rig, c, cols, rows, label, opt, &fs, &out.tile_q);
  if (hysteresis) {
    // A labelled tile keeps the prior's depth unless its new plane is
    // cheaper there by more than change_penalty percent of the contrast.
    // plane_for(q): the plane of inverse depth q: the single plane, a
    // label's, one kept before, or a new one (-1: kMaxPlanes already).
    std::vector<std::pair<double, int>> kept;
    auto plane_for = [&](double q) {
      if (q == out.single_q) return 0;
      const auto l = std::find(c.qs.begin(), c.qs.end(), q);
      if (l != c.qs.end() && plane_of_label[l - c.qs.begin()] >= 0)
        return plane_of_label[l - c.qs.begin()];
      for (const auto& [kq, plane] : kept)
        if (kq == q) return plane;
      if (fs.planes.size() >= static_cast<size_t>(FocalSurface::kMaxPlanes)) return -1;
      fs.planes.push_back(plane_at_inverse_depth(rig, q));
      kept.emplace_back(q, static_cast<int>(fs.planes.size()) - 1);
      return kept.back().second;
    };
    std::vector<double> cost(M);
    const std::vector<int> own = own_best(c, tiles);
    for (int r = 0; r < rows; ++r)
      for (int q = 0; q < cols; ++q) {
        const int t = r * cols + q;
        const double was = prior->tile_q[t];
        if (label[t] < 0 || !std::isfinite(was) || was == out.tile_q[t]) continue;
        double m = 0;
        for (int k = 0; k < M; ++k)
          cost[k] = neighbourhood_cost(c, cols, rows, r, q, k, own, opt, &m);
        const double cost_was = interpolate_at(c.qs, cost, was);
        if (!(cost_was <= interpolate_at(c.qs, cost, out.tile_q[t]) + opt.change_penalty * scale))
          continue;
        const int plane = plane_for(was);
        if (plane < 0) continue;  // no room for another plane
        fs.plane_of[t] = static_cast<uint8_t>(plane);
        out.tile_q[t] = was;
        ++out.kept_tiles;
      }
  }
  if (opt.second_planes) {
    // A tile next to a depth edge holds both depths: its second plane is
    // the plane among its 8 labelled neighbours' furthest from its own, when
    // that is at least second_gap planes of the first pass away (in inverse
    // depth: the costs may be a finer sweep's). The tiles' depths are the
    // ones they have now: a tile that kept the prior's depth may have the
    // plane of a neighbour's new label, which is then no second plane.
    fs.second_of.assign(tiles, FocalSurface::kNone);
    const double min_dq = opt.second_gap * sweep_q_max(rig, opt) / (opt.planes - 1);
    const std::vector<double>& tq = out.tile_q;
    for (int r = 0; r < rows; ++r)
      for (int q = 0; q < cols; ++q) {
        const int t = r * cols + q;
        if (label[t] < 0) continue;
        int far = -1;
        for (int dr = -1; dr <= 1; ++dr)
          for (int dq = -1; dq <= 1; ++dq) {
            const int rr = r + dr, qq = q + dq, u = rr * cols + qq;
            if (rr < 0 || qq < 0 || rr >= rows || qq >= cols || label[u] < 0) continue;
            if (std::abs(tq[u] - tq[t]) < min_dq) continue;
            if (far < 0 || std::abs(tq[u] - tq[t]) > std::abs(tq[far] - tq[t])) far = u;
          }
        if (far >= 0) fs.second_of[t] = fs.plane_of[far];
      }
    if (cells && cells->cell > 0) {
      const SweepCosts& cc = *cells;
      const int C = cc.cell, per = opt.tile / C, K = static_cast<int>(cc.qs.size());
      const size_t n = static_cast<size_t>(cc.cell_cols) * cc.cell_rows;
      if (opt.tile % C || K < 3 || cc.cell_sum.size() != K * n || cc.cell_count.size() != K * n ||
          cc.cell_cols < (cols - 1) * per + 1 || cc.cell_rows < (rows - 1) * per + 1)
        throw std::invalid_argument("surface_from_costs: per-cell costs do not fit the tiles");
      // Each tile's cells vote; best_of[t] is the plane with the most votes
      // (with its two neighbours), votes_of[t] their number.
      std::vector<int> votes(K), plane_of_cell_label(K, -1), best_of(tiles, -1), votes_of(tiles, 0);
      // Every tile's votes per plane, for the growth below.
      std::vector<int> voted(static_cast<size_t>(tiles) * K, 0);
      std::vector<double> cost(K);
      for (int r = 0; r < rows; ++r)
        for (int q = 0; q < cols; ++q) {
          const int t = r * cols + q;
          if (label[t] < 0 || fs.second_of[t] != FocalSurface::kNone) continue;
          // The tile's plane among the cells' planes: the nearest.
          int own = 0;
          for (int k = 1; k < K; ++k)
            if (std::abs(cc.qs[k] - out.tile_q[t]) < std::abs(cc.qs[own] - out.tile_q[t])) own = k;
          std::fill(votes.begin(), votes.end(), 0);
          for (int cr = r * per; cr < std::min((r + 1) * per, cc.cell_rows); ++cr)
            for (int cq = q * per; cq < std::min((q + 1) * per, cc.cell_cols); ++cq) {
              const size_t i = static_cast<size_t>(cr) * cc.cell_cols + cq;
              bool seen = true;
              for (int k = 0; k < K && seen; ++k) {
                const double m = cc.cell_count[k * n + i];
                seen = m > 0;
                cost[k] = seen ? cc.cell_sum[k * n + i] / m : 0.0;
              }
              if (!seen) continue;
              const int b =
                  static_cast<int>(std::min_element(cost.begin(), cost.end()) - cost.begin());
              if (std::abs(cc.qs[b] - out.tile_q[t]) >= min_dq &&
                  cost[b] <= opt.thin_ratio * cost[own] &&
                  cost[own] - cost[b] >= opt.thin_margin * scale)
                ++votes[b];
            }
          std::copy(votes.begin(), votes.end(), voted.begin() + static_cast<size_t>(t) * K);
          for (int k = 0; k < K; ++k) {
            const int v = votes[k] + (k > 0 ? votes[k - 1] : 0) + (k + 1 < K ? votes[k + 1] : 0);
            if (votes[k] > 0 &&
                (v > votes_of[t] || (v == votes_of[t] && votes[k] > votes[best_of[t]])))
              best_of[t] = k, votes_of[t] = v;
          }
        }
      std::vector<int> thin_k(tiles, -1);  // the thin structure's plane per tile (of cc.qs)
      for (int r = 0; r < rows; ++r)
        for (int q = 0; q < cols; ++q) {
          const int t = r * cols + q, best = best_of[t];
          if (best < 0 || votes_of[t] < std::max(2.0, opt.thin_fraction * per * per)) continue;
          int nb = 0;
          for (int dr = -1; dr <= 1; ++dr)
            for (int dq = -1; dq <= 1; ++dq) {
              const int rr = r + dr, qq = q + dq;
              if ((dr || dq) && rr >= 0 && qq >= 0 && rr < rows && qq < cols &&
                  best_of[rr * cols + qq] >= 0 && std::abs(best_of[rr * cols + qq] - best) <= 1)
                ++nb;
            }
          if (nb < opt.thin_neighbours) continue;
          thin_k[t] = best;
        }
      // A structure runs on: from the tiles found, it grows into every
      // neighbouring tile (8-connected, on and on) with thin_grow_votes
      // cells that voted within a plane of it.
      std::vector<int> grow;
      for (int t = 0; t < tiles; ++t)
        if (thin_k[t] >= 0) grow.push_back(t);
      while (!grow.empty()) {
        const int t = grow.back(), k = thin_k[t];
        grow.pop_back();
        for (int dr = -1; dr <= 1; ++dr)
          for (int dq = -1; dq <= 1; ++dq) {
            const int rr = t / cols + dr, qq = t % cols + dq, u = rr * cols + qq;
            if (rr < 0 || qq < 0 || rr >= rows || qq >= cols || thin_k[u] >= 0 || label[u] < 0 ||
                fs.second_of[u] != FocalSurface::kNone)
              continue;
            const int* v = &voted[static_cast<size_t>(u) * K];
            int best = -1;
            for (int j = std::max(0, k - 1); j <= std::min(K - 1, k + 1); ++j)
              if (v[j] >= opt.thin_grow_votes && (best < 0 || v[j] > v[best])) best = j;
            if (best >= 0) thin_k[u] = best, grow.push_back(u);
          }
      }
      // A structure on a tile's border: the 4 neighbours of the tiles found
      // get its plane too, each the one of its neighbours' planes that its
      // own cells voted for most (within a plane).
      if (opt.thin_spread) {
        const std::vector<int> found = thin_k;
        for (int t = 0; t < tiles; ++t) {
          if (found[t] >= 0 || label[t] < 0 || fs.second_of[t] != FocalSurface::kNone) continue;
          const int r = t / cols, q = t % cols;
          const int* v = &voted[static_cast<size_t>(t) * K];
          int most = -1;
          for (const auto& [dr, dq] : {std::pair{-1, 0}, {1, 0}, {0, -1}, {0, 1}}) {
            const int rr = r + dr, qq = q + dq;
            if (rr < 0 || qq < 0 || rr >= rows || qq >= cols) continue;
            const int k = found[rr * cols + qq];
            if (k < 0) continue;
            const int n = v[k] + (k > 0 ? v[k - 1] : 0) + (k + 1 < K ? v[k + 1] : 0);
            if (n > most) most = n, thin_k[t] = k;
          }
        }
      }
      for (int t = 0; t < tiles; ++t) {
        const int k = thin_k[t];
        if (k < 0) continue;
        if (plane_of_cell_label[k] < 0) {
          // A surface holds at most kMaxPlanes (hysteresis may have filled it).
          if (fs.planes.size() >= static_cast<size_t>(FocalSurface::kMaxPlanes)) continue;
          plane_of_cell_label[k] = static_cast<int>(fs.planes.size());
          fs.planes.push_back(plane_at_inverse_depth(rig, cc.qs[k]));
        }
        fs.second_of[t] = static_cast<uint8_t>(plane_of_cell_label[k]);
        ++out.thin_tiles;
      }
    }
    out.two_plane_tiles = fs.two_plane_tiles();
    if (out.two_plane_tiles == 0) fs.second_of.clear();
  }
  out.planes_used = fs.planes_used();
  if (out.planes_used == 1 && fs.plane_of[0] != 0) {
    // Every tile agrees on one plane other than the single: that is the plane.
    out.single = fs.planes[fs.plane_of[0]];
    out.single_q = out.tile_q[0];
  } else if (out.planes_used > 1) {
    out.surface = std::move(fs);
  }
  return out;
}

void apply(const SurfaceEstimate& e, ViewRequest& req) {
  req.focal_plane = e.single;
  req.surface = e.surface;
}

std::vector<double> tile_disparity_errors(const Rig& rig, const SurfaceEstimate& e,
                                          const std::vector<double>& tile_q, const cv::Mat& gt,
                                          int tile, double baseline) {
  if (gt.type() != CV_32FC1 || tile < 1)
    throw std::invalid_argument("tile_disparity_errors: the ground truth must be CV_32FC1");
  const int cols = (gt.cols + tile - 1) / tile, rows = (gt.rows + tile - 1) / tile;
  const size_t tiles = static_cast<size_t>(cols) * rows;
  if (tile_q.size() != tiles || e.textured.size() != tiles)
    throw std::invalid_argument("tile_disparity_errors: " + std::to_string(tile_q.size()) +
                                " depths and " + std::to_string(e.textured.size()) +
                                " texture flags for " + std::to_string(tiles) + " tiles");
  std::vector<double> err;
  std::vector<float> d;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      const size_t t = static_cast<size_t>(r) * cols + c;
      if (!e.textured[t]) continue;
      const cv::Rect box =
          cv::Rect(c * tile, r * tile, tile, tile) & cv::Rect(0, 0, gt.cols, gt.rows);
      d.assign(box.area(), 0.0f);
      for (int y = 0; y < box.height; ++y)
        std::copy_n(gt.ptr<float>(box.y + y) + box.x, box.width, d.begin() + y * box.width);
      std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
      err.push_back(
          std::abs(-baseline * focal_param_from_inverse_depth(rig, tile_q[t]) - d[d.size() / 2]));
    }
  std::sort(err.begin(), err.end());
  return err;
}

}  // namespace lf
