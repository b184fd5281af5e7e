#include "lf/focus/surface_probe.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/core/utility.hpp>

#include "lf/focus/focus.h"

namespace lf {

std::vector<ViewRequest> surface_probe_requests(const Rig& rig, const ViewRequest& view,
                                                uint32_t probe_id, const SurfaceOptions& opt) {
  validate(opt);
  const double q_max = sweep_q_max(rig, opt);
  ViewRequest base = scaled_request(view, std::min(opt.analysis_width, view.view.width));
  base.aperture_scale = 1;              // photo-consistency among the tent's cameras
  base.sampling = Sampling::kBilinear;  // the cheaper warp
  std::vector<ViewRequest> out;
  for (int k = 0; k < opt.planes; ++k) {
    ViewRequest r = base;
    r.focal_plane = plane_at_inverse_depth(rig, q_max * k / (opt.planes - 1));
    r.sequence = surface_probe_sequence(probe_id, k);
    out.push_back(r);
  }
  return out;
}

SurfaceProbeAnswers::SurfaceProbeAnswers(int width, int height, SurfaceOptions opt)
    : width_(width), height_(height), opt_(opt) {
  validate(opt);
  if (width < 2 || height < 2)
    throw std::invalid_argument("surface probe: output " + std::to_string(width) + "x" +
                                std::to_string(height));
  // The probe's size, as scaled_request makes it.
  aw_ = std::min(opt.analysis_width, width);
  ah_ = std::max(2, static_cast<int>(std::lround(height * static_cast<double>(aw_) / width)));
}

bool SurfaceProbeAnswers::add(int step, Fragment f) {
  if (f.out_width != aw_ || f.out_height != ah_) return false;
  const size_t budget = kMaxOverlap * static_cast<size_t>(opt_.planes) * aw_ * ah_;
  const size_t n = f.pixel_count();
  if (pixels_ + n > budget || !keep(step, opt_.planes, std::move(f))) return false;
  pixels_ += n;
  return true;
}

SurfaceEstimate SurfaceProbeAnswers::estimate(const Rig& rig, bool* ok, const SurfacePrior* prior,
                                              bool every_core) const {
  // The steps that every complete camera answered (the same set for all of
  // them, so every plane compares the same cameras).
  std::vector<int> answered(opt_.planes, 0);
  for_each_complete([&](int step, const Fragment&) { answered[step]++; });
  const int complete = complete_cameras();
  std::vector<int> steps;
  for (int k = 0; k < opt_.planes; ++k)
    if (complete > 0 && answered[k] == complete) steps.push_back(k);
  const int T = opt_.tile;
  const int cols = (width_ + T - 1) / T, rows = (height_ + T - 1) / T, tiles = cols * rows;
  // Nothing to estimate from: a single plane at infinity, and ok false.
  auto none = [&] {
    if (ok) *ok = false;
    SurfaceEstimate e;
    e.single = FocalPlane::infinity();
    e.tile_q.assign(tiles, 0.0);
    e.textured.assign(tiles, false);
    return e;
  };
  if (steps.size() < 3) return none();
  const double q_max = sweep_q_max(rig, opt_);
  SweepCosts c;
  for (const int k : steps) c.qs.push_back(q_max * k / (opt_.planes - 1));
  const size_t n = steps.size();
  c.sum.assign(n * tiles, 0.0);
  c.count.assign(n * tiles, 0.0);
  c.have.assign(n, true);
  // With second planes, per-cell costs too: thin structures inside tiles.
  const int C = opt_.second_planes ? thin_cell(T, aw_, width_) : 0;
  if (C) {
    c.cell = C, c.cell_cols = (width_ + C - 1) / C, c.cell_rows = (height_ + C - 1) / C;
    c.cell_sum.assign(n * c.cell_cols * c.cell_rows, 0.0);
    c.cell_count.assign(c.cell_sum.size(), 0.0);
  }
  // Tile (and cell) of each probe column and row (as the estimator's sweep).
  const std::vector<int> tx = analysis_bins(aw_, width_, T), ty = analysis_bins(ah_, height_, T);
  const std::vector<int> cx = analysis_bins(C ? aw_ : 0, width_, C),
                         cy = analysis_bins(C ? ah_ : 0, height_, C);
  // Per probe pixel: sum w, sum w g, sum w g^2 (g: grey level of the
  // un-premultiplied colour, (c0 + 2 c1 + c2) / 4, the same for RGBA and
  // BGRA), one step at a time. The steps on every core (`every_core`):
  // each writes only its own costs, and adds its fragments in the same
  // order as one thread would, so the estimate does not depend on the
  // threads.
  const size_t npx = static_cast<size_t>(aw_) * ah_;
  const float cap = static_cast<float>(opt_.truncate * opt_.truncate);
  auto gather = [&](const cv::Range& range) {
    std::vector<float> s0(npx), s1(npx), s2(npx);
    for (int i = range.start; i < range.end; ++i) {
      std::fill(s0.begin(), s0.end(), 0.0f);
      std::fill(s1.begin(), s1.end(), 0.0f);
      std::fill(s2.begin(), s2.end(), 0.0f);
      for_each_complete([&](int step, const Fragment& f) {
        if (step != steps[i] || f.empty()) return;
        const uint8_t* px = f.pixels.data();
        for (int row = 0; row < f.rect.height; ++row) {
          const size_t base = static_cast<size_t>(f.rect.y + row) * aw_;
          for (int x = f.spans[row][0]; x < f.spans[row][1]; ++x, px += 4) {
            if (px[3] == 0) continue;
            const float w = px[3] / 255.0f;
            const float g = (px[0] + 2.0f * px[1] + px[2]) / 4.0f;  // w times the grey level
            s0[base + x] += w;
            s1[base + x] += g;
            s2[base + x] += g * g / w;
          }
        }
      });
      double* sum = &c.sum[static_cast<size_t>(i) * tiles];
      double* cnt = &c.count[static_cast<size_t>(i) * tiles];
      for (int y = 0; y < ah_; ++y)
        for (int x = 0; x < aw_; ++x) {
          const size_t k = static_cast<size_t>(y) * aw_ + x;
          if (s0[k] < 0.9f) continue;  // most of the aperture must see the point
          const float m = s1[k] / s0[k];
          const int t = ty[y] * cols + tx[x];
          const float v = std::min(std::max(0.0f, s2[k] / s0[k] - m * m), cap);
          sum[t] += v;
          cnt[t] += 1.0;
          if (C) {
            const size_t cell =
                (static_cast<size_t>(i) * c.cell_rows + cy[y]) * c.cell_cols + cx[x];
            c.cell_sum[cell] += v;
            c.cell_count[cell] += 1.0;
          }
        }
    }
  };
  const cv::Range all(0, static_cast<int>(n));
  if (every_core)
    cv::parallel_for_(all, gather);
  else
    gather(all);
  // No pixel seen by most of the aperture at any plane (every camera sat
  // the probe out, or sees none of the view): nothing to estimate from.
  if (std::all_of(c.count.begin(), c.count.end(), [](double v) { return v == 0; })) return none();
  if (ok) *ok = true;
  return surface_from_costs(rig, c, cols, rows, std::numeric_limits<double>::quiet_NaN(),
                            0.5 * static_cast<double>(npx) / tiles, opt_, C ? &c : nullptr, prior);
}

}  // namespace lf
