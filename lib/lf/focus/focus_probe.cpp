#include "lf/focus/focus_probe.h"

#include <algorithm>
#include <cmath>

#include "lf/focus/focal_surface.h"
#include "lf/focus/focus.h"
#include "lf/geometry/view_builder.h"

namespace lf {

double focus_probe_inverse_depth(const Rig& rig, int step) {
  const double f = rig.cameras.at(0).intrinsics.fx;
  const double q_max = kFocusProbeMaxParallaxPx / (f * rig.typical_spacing());
  return q_max * step / (kFocusProbeSteps - 1);
}

// The probe's eye: the centre of the aperture simplex (triangle, segment or
// point) around where the ray meets the camera plane (clamped onto the
// array), on the camera plane, so that every pixel of the probe blends all
// of the simplex's cameras with equal weight (an eye at a camera would see
// through that camera alone: nothing to compare).
static cv::Vec3d probe_eye(const Rig& rig, const cv::Vec3d& eye, const cv::Vec3d& d) {
  const CameraPlane& P = rig.plane();
  const double dn = d.dot(P.normal);
  const cv::Vec3d hit =
      std::abs(dn) > 1e-12 ? cv::Vec3d(eye - d * (P.signed_distance(eye) / dn)) : eye;
  const cv::Vec2d p = clamp_to_array(rig, P.to_plane(hit));
  const auto& pos = rig.plane_positions();
  double best = -1e300;
  cv::Vec2d centre = p;
  for (const Simplex& sx : rig.simplices()) {
    // Smallest barycentric-like margin: the distance to the simplex's nearest
    // facet (positive inside); the simplex that contains p has the largest.
    double margin = 1e300;
    for (int i = 0; i < sx.size && sx.size > 1; ++i)
      margin = std::min(margin, sx.sign[i] * rig.facets()[sx.facet[i]](p));
    if (sx.size == 1) margin = -cv::norm(pos[sx.cams[0]] - p);
    if (margin <= best) continue;
    best = margin;
    centre = {0, 0};
    for (int i = 0; i < sx.size; ++i) centre += pos[sx.cams[i]] / sx.size;
  }
  return P.origin + P.u * centre[0] + P.v * centre[1];
}

std::vector<ViewRequest> focus_probe_requests(const Rig& rig, const ViewRequest& view, double x,
                                              double y, uint32_t probe_id) {
  const int side = kFocusProbeSide;
  const VirtualView& v = view.view;
  const Intrinsics k = v.intrinsics();
  // The clicked pixel's ray, world frame.
  cv::Vec3d d = v.R.t() * cv::Vec3d((x - k.cx) / k.fx, (y - k.cy) / k.fy, 1.0);
  d /= cv::norm(d);
  const CameraPlane& P = rig.plane();
  const cv::Vec3d C = probe_eye(rig, v.position, d);
  VirtualView w = v;
  w.position = C;
  w.width = w.height = side;
  // Same focal length in pixels: fy = (side / 2) / tan(vfov_w / 2).
  w.vfov_deg = 2.0 * std::atan(0.5 * side / k.fy) * 180.0 / M_PI;
  std::vector<ViewRequest> out;
  for (int s = 0; s < kFocusProbeSteps; ++s) {
    const double q = focus_probe_inverse_depth(rig, s);
    // Where the ray meets the candidate plane (or its direction, at
    // infinity), seen from the probe's eye: the window is centred there.
    cv::Vec3d c;
    const double dn = d.dot(P.normal);
    if (q > 0 && dn > 1e-12) {
      const cv::Vec3d X = v.position + d * ((1.0 / q - P.signed_distance(v.position)) / dn);
      c = v.R * (X - C);
    } else {
      c = v.R * d;
    }
    if (c[2] <= 0) continue;  // behind the probe's eye: no window
    ViewRequest req = view;
    req.surface = {};                    // the window has its own size: one plane per step
    req.aperture_scale = 1;              // photo-consistency among the tent's cameras
    req.sampling = Sampling::kBilinear;  // the cheaper warp
    req.view = w;
    req.view.shift_x = k.cx - (k.fx * c[0] / c[2] + k.cx);
    req.view.shift_y = k.cy - (k.fy * c[1] / c[2] + k.cy);
    req.sequence = focus_probe_sequence(probe_id, s);
    req.focal_plane = plane_at_inverse_depth(rig, q);
    out.push_back(req);
  }
  return out;
}

FocusProbeScore::FocusProbeScore()
    : sums_(static_cast<size_t>(kFocusProbeSteps) * kSide * kSide * 7, 0.0),
      cameras_(static_cast<size_t>(kFocusProbeSteps) * kSide * kSide, 0) {}

void FocusProbeScore::add(int step, const Fragment& f) {
  if (step < 0 || step >= kFocusProbeSteps || f.out_width != kSide || f.out_height != kSide) return;
  const uint8_t* px = f.pixels.data();
  for (int row = 0; row < f.rect.height; ++row) {
    const int y = f.rect.y + row;
    for (int x = f.spans[row][0]; x < f.spans[row][1]; ++x, px += 4) {
      const double w = px[3] / 255.0;
      if (w <= 0) continue;
      const size_t i = (static_cast<size_t>(step) * kSide + y) * kSide + x;
      double* s = &sums_[i * 7];
      s[0] += w;
      for (int c = 0; c < 3; ++c) {
        const double colour = px[c] / w;  // un-premultiplied, 8-bit levels
        s[1 + c] += w * colour;
        s[4 + c] += w * colour * colour;
      }
      cameras_[i]++;
    }
  }
}

double FocusProbeScore::variance(int step, int p) const {
  const size_t i = static_cast<size_t>(step) * kSide * kSide + p;
  if (cameras_[i] < 2) return -1;
  const double* v = &sums_[i * 7];
  double var = 0;
  for (int c = 0; c < 3; ++c) {
    const double mean = v[1 + c] / v[0];
    var += std::max(0.0, v[4 + c] / v[0] - mean * mean);
  }
  return var / 3;
}

std::vector<double> FocusProbeScore::costs() const {
  std::vector<double> out(kFocusProbeSteps, -1.0);
  for (int s = 0; s < kFocusProbeSteps; ++s) {
    double total = 0;
    int n = 0;
    for (int p = 0; p < kSide * kSide; ++p) {
      const double var = variance(s, p);
      if (var < 0) continue;
      total += std::min(25.0, std::sqrt(var));
      ++n;
    }
    if (n > 0) out[s] = total / n;
  }
  return out;
}

bool FocusProbeScore::best(const Rig& rig, double* inverse_depth) const {
  // The focal surface estimator on the window (lf/focus/focal_surface.h): per
  // step, the cost of each tile of kFocusProbeTile pixels (the cameras'
  // colour variance per channel, levels^2, truncated as the estimator's
  // grey-level variance is), labelled by surface_from_costs.
  constexpr int T = kFocusProbeTile, cols = (kSide + T - 1) / T, tiles = cols * cols;
  constexpr double kCap = 25.0 * 25.0;
  SweepCosts c;
  std::vector<double> sum(tiles), count(tiles);
  for (int s = 0; s < kFocusProbeSteps; ++s) {
    std::fill(sum.begin(), sum.end(), 0.0);
    std::fill(count.begin(), count.end(), 0.0);
    for (int p = 0; p < kSide * kSide; ++p) {
      const double var = variance(s, p);
      if (var < 0) continue;
      const int t = (p / kSide / T) * cols + (p % kSide) / T;
      sum[t] += std::min(kCap, var);
      count[t] += 1;
    }
    if (std::all_of(count.begin(), count.end(), [](double n) { return n == 0; }))
      continue;  // a step no pixel of which two cameras saw
    c.qs.push_back(focus_probe_inverse_depth(rig, s));
    c.sum.insert(c.sum.end(), sum.begin(), sum.end());
    c.count.insert(c.count.end(), count.begin(), count.end());
  }
  const int planes = static_cast<int>(c.qs.size());
  if (planes < kFocusProbeSteps / 2) return false;
  SurfaceOptions opt;
  opt.tile = T;
  opt.sub_steps = 1;  // the clicked tile is refined below, on its own pixels' costs
  const SurfaceEstimate e =
      surface_from_costs(rig, c, cols, cols, NAN, 0.5 * T * T, opt);  // half a tile's pixels
  // The clicked pixel's tile: its label's plane when that is one of the
  // sweep's (the single plane is refined already), then the least cost of
  // the tile's own pixels (not aggregated with its neighbours, which may
  // lie at another depth) within a plane of it, refined by a parabola.
  const int centre = (kFocusProbeRadius / T) * cols + kFocusProbeRadius / T;
  double q = e.tile_q[centre];
  int k = static_cast<int>(std::find(c.qs.begin(), c.qs.end(), q) - c.qs.begin());
  if (k < planes && c.count[static_cast<size_t>(k) * tiles + centre] > 0) {
    auto own = [&](int j) {
      const size_t at = static_cast<size_t>(j) * tiles + centre;
      return c.count[at] > 0 ? c.sum[at] / c.count[at] : kCap;
    };
    if (k > 0 && own(k - 1) < own(k))
      --k;
    else if (k + 1 < planes && own(k + 1) < own(k))
      ++k;
    q = c.qs[k];
    if (k > 0 && k + 1 < planes) {
      const double a = own(k - 1), b = own(k), d = own(k + 1), den = a - 2 * b + d;
      if (den > 1e-12) {
        const double x = std::clamp(0.5 * (a - d) / den, -0.5, 0.5);
        q += x * (x < 0 ? q - c.qs[k - 1] : c.qs[k + 1] - q);
      }
    }
  }
  *inverse_depth = q;
  return true;
}

bool FocusProbeAnswers::best(const Rig& rig, double* inverse_depth) const {
  FocusProbeScore score;
  for_each_complete([&](int step, const Fragment& f) { score.add(step, f); });
  return score.best(rig, inverse_depth);
}

}  // namespace lf
