#include "lf/focus/focus.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "lf/geometry/rig_ops.h"
#include "lf/render/plan.h"

namespace lf {

namespace {
double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
}  // namespace

FocalPlane plane_at_inverse_depth(const Rig& rig, double q) {
  const CameraPlane& P = rig.plane();
  if (q == 0) return FocalPlane::infinity();
  // n . X + d = 0 with n = q N: q N.(X - O) - 1 = 0.
  return {P.normal * q, -q * P.normal.dot(P.origin) - 1.0};
}

FocalPlane plane_at_depth(const Rig& rig, double z) {
  if (std::isinf(z)) return FocalPlane::infinity();
  if (!(z != 0) || !std::isfinite(z)) throw std::invalid_argument("focal depth must be non-zero");
  return FocalPlane::through(rig.plane().origin + rig.plane().normal * z, rig.plane().normal);
}

FocalPlane plane_from_focal_param(const Rig& rig, double a) {
  if (!rig.has_focal_param)
    throw std::invalid_argument("rig '" + rig.name + "' has no light-slab focal parameter");
  // z = f / (a_inf - a)  <=>  q = (a_inf - a) / f
  return plane_at_inverse_depth(rig, (rig.focal_param_infinity - a) / rig.focal_param_f_px);
}

double inverse_depth_of(const Rig& rig, const FocalPlane& p) {
  if (p.at_infinity()) return 0.0;
  const CameraPlane& P = rig.plane();
  const double nn = p.n.dot(P.normal), off = p.n.dot(P.origin) + p.d;
  if (nn == 0 || off == 0) return 0.0;
  return std::max(0.0, -nn / off);
}

double focal_param_from_inverse_depth(const Rig& rig, double q) {
  if (!rig.has_focal_param)
    throw std::invalid_argument("rig '" + rig.name + "' has no light-slab focal parameter");
  return rig.focal_param_infinity - q * rig.focal_param_f_px;
}

// ---------------------------------------------------------------------------
// Auto-focus

ViewRequest scaled_request(const ViewRequest& req, int width) {
  ViewRequest r = req;
  const double s = static_cast<double>(width) / req.view.width;
  r.view.width = width;
  r.view.height = std::max(2, static_cast<int>(std::lround(req.view.height * s)));
  // Keep the field of view of the full-size view.
  const double f_full = req.view.focal_px();
  const double f_new = f_full * r.view.height / req.view.height;
  r.view.vfov_deg = 2.0 * std::atan(0.5 * r.view.height / f_new) * 180.0 / CV_PI;
  r.view.shift_x = req.view.shift_x * s;
  r.view.shift_y = req.view.shift_y * s;
  r.surface = {};
  return r;
}

namespace {
float bilinear(const cv::Mat& g, float u, float v) {
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const float fx = u - x, fy = v - y;
  const float* r0 = g.ptr<float>(y) + x;
  const float* r1 = g.ptr<float>(y + 1) + x;
  return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}
}  // namespace

double refined_minimum(const std::vector<double>& cost) {
  const int n = static_cast<int>(cost.size());
  const int k = static_cast<int>(std::min_element(cost.begin(), cost.end()) - cost.begin());
  if (k == 0 || k == n - 1) return k;
  const double a = cost[k - 1], b = cost[k], c = cost[k + 1];
  const double den = a - 2 * b + c;
  return den > 0 ? k + std::clamp(0.5 * (a - c) / den, -0.5, 0.5) : k;
}

AnalysisImages analysis_images(const Rig& rig, const std::vector<cv::Mat>& images, int width) {
  if (images.size() != rig.cameras.size())
    throw std::invalid_argument("analysis images: image count does not match the rig");
  std::vector<double> widths;
  for (const Camera& c : rig.cameras) widths.push_back(c.width);
  const double scale = std::min(1.0, 1.5 * width / median(widths));
  AnalysisImages out{scale_rig(rig, scale), std::vector<cv::Mat>(images.size()), width};
  for (size_t i = 0; i < images.size(); ++i) {
    cv::Mat small, g;
    cv::resize(images[i], small, cv::Size(out.rig.cameras[i].width, out.rig.cameras[i].height), 0,
               0, cv::INTER_AREA);
    cv::cvtColor(small, g, cv::COLOR_BGRA2GRAY);
    g.convertTo(out.gray[i], CV_32F);
  }
  return out;
}

void photo_consistency(const Rig& rig, const std::vector<cv::Mat>& gray, const ViewRequest& req_in,
                       double q, double truncate, cv::Mat& cost) {
  ViewRequest req = req_in;
  req.surface = {};
  req.focal_plane = plane_at_inverse_depth(rig, q);
  const ViewGeometry g(rig, req);
  const int W = req.view.width, H = req.view.height;
  std::vector<float> s0(static_cast<size_t>(W) * H, 0), s1(s0.size(), 0), s2(s0.size(), 0);
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const FragmentPlan plan = plan_fragment(g, static_cast<int>(i));
    if (plan.empty()) continue;
    const Camera& cam = rig.cameras[i];
    const cv::Mat& img = gray[i];
    for (const Run& run : plan.runs) {
      const FragmentPiece& pc = plan.pieces[run.piece];
      // The weight's terms and the homography are affine in x along a row.
      const double y = run.y;
      const double num_y = pc.weight_num.b * y + pc.weight_num.c,
                   den_y = pc.weight_den.b * y + pc.weight_den.c;
      const cv::Matx33d& H = pc.H;
      const double h0_y = H(0, 1) * y + H(0, 2), h1_y = H(1, 1) * y + H(1, 2),
                   h2_y = H(2, 1) * y + H(2, 2);
      for (int x = run.x0; x < run.x1; ++x) {
        const double den = pc.weight_den.a * x + den_y;
        const double w = den != 0 ? std::clamp((pc.weight_num.a * x + num_y) / den, 0.0, 1.0) : 0.0;
        const double hz = H(2, 0) * x + h2_y;
        if (!(hz > 0) || !(w > 0)) continue;
        cv::Vec2d p((H(0, 0) * x + h0_y) / hz, (H(1, 0) * x + h1_y) / hz);
        if (cam.intrinsics.has_distortion()) p = cam.distort_pixel(p);
        // Checked after rounding to float: 238.9999999 becomes 239.0f, whose
        // bilinear neighbour would be a row past the image.
        const float u = static_cast<float>(p[0]), v = static_cast<float>(p[1]);
        if (!(u >= 0 && v >= 0 && u < img.cols - 1 && v < img.rows - 1)) continue;
        const float c = bilinear(img, u, v);
        const size_t k = static_cast<size_t>(run.y) * W + x;
        s0[k] += static_cast<float>(w);
        s1[k] += static_cast<float>(w) * c;
        s2[k] += static_cast<float>(w) * c * c;
      }
    }
  }
  const float cap = static_cast<float>(truncate * truncate);
  cost.create(H, W, CV_32F);
  float* out = cost.ptr<float>();
  for (size_t k = 0; k < s0.size(); ++k) {
    if (s0[k] < 0.9f) {  // most of the aperture must see the point
      out[k] = -1.0f;
      continue;
    }
    const double m = static_cast<double>(s1[k]) / s0[k];
    out[k] = static_cast<float>(std::min(std::max(0.0, s2[k] / s0[k] - m * m), double{cap}));
  }
}

AutofocusContext::AutofocusContext(const Rig& rig, const std::vector<cv::Mat>& images,
                                   AutofocusOptions opt)
    : rig_(&rig), opt_(opt) {
  for (int width : {opt.coarse_width, opt.fine_width})
    levels_.push_back(analysis_images(rig, images, width));
}

double AutofocusContext::sweep_cost(const ViewRequest& req, int width, double q, int level) const {
  cv::Mat cost;
  photo_consistency(levels_[level].rig, levels_[level].gray, scaled_request(req, width), q,
                    opt_.truncate, cost);
  double sum = 0;
  size_t count = 0;
  for (const float* c = cost.ptr<float>(); c != cost.ptr<float>() + cost.total(); ++c)
    if (*c >= 0) sum += *c, ++count;
  return count ? sum / count : opt_.truncate * opt_.truncate;
}

AutofocusResult AutofocusContext::run(const ViewRequest& req) const {
  std::vector<double> f;
  for (const Camera& c : rig_->cameras) f.push_back(c.intrinsics.fx);
  const double q_max = opt_.max_parallax_px / (median(f) * rig_->typical_spacing());
  AutofocusResult res;
  const int nc = std::max(3, opt_.coarse_steps);
  std::vector<double> qs(nc), cost(nc);
  for (int k = 0; k < nc; ++k) {
    qs[k] = q_max * k / (nc - 1);
    cost[k] = sweep_cost(req, std::min(opt_.coarse_width, req.view.width), qs[k], 0);
    res.curve.emplace_back(qs[k], cost[k]);
  }
  const int kb = static_cast<int>(std::min_element(cost.begin(), cost.end()) - cost.begin());
  const double lo = qs[std::max(0, kb - 1)], hi = qs[std::min(nc - 1, kb + 1)];
  const int nf = std::max(3, opt_.fine_steps);
  std::vector<double> fq(nf), fc(nf);
  for (int k = 0; k < nf; ++k) {
    fq[k] = lo + (hi - lo) * k / (nf - 1);
    fc[k] = sweep_cost(req, std::min(opt_.fine_width, req.view.width), fq[k], 1);
    res.curve.emplace_back(fq[k], fc[k]);
  }
  const double pos = refined_minimum(fc);
  const int fb = static_cast<int>(std::lround(pos));
  const double q = fq[fb] + (pos - fb) * (fq[1] - fq[0]);
  res.inverse_depth = std::max(0.0, q);
  res.plane = plane_at_inverse_depth(*rig_, res.inverse_depth);
  return res;
}

}  // namespace lf
