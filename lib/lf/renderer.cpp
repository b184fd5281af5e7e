#include "lf/renderer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/quality/qualityssim.hpp>
#include <stdexcept>

#include "lf/datasets.h"

namespace lf {

namespace {
double now_ms() {
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}
double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}
}  // namespace

cv::Mat render_view(const Rig& rig, const std::vector<cv::Mat>& images, const ViewRequest& req,
                    RenderStats* stats, int threads) {
  if (images.size() != rig.cameras.size())
    throw std::invalid_argument("render_view: " + std::to_string(images.size()) + " images for " +
                                std::to_string(rig.cameras.size()) + " cameras");
  const double t0 = now_ms();
  const ViewGeometry g(rig, req);
  const int n = static_cast<int>(rig.cameras.size());
  std::vector<FragmentPlan> plans(n);
  std::vector<Fragment> frags(n);
  double t1 = 0, t2 = 0;
  auto work = [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) {
      plans[i] = plan_fragment(g, i);
      frags[i].viewer_id = req.viewer_id;
      frags[i].sequence = req.sequence;
    }
  };
  auto draw = [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i)
      render_fragment(plans[i], rig.cameras[i], images[i], frags[i]);
  };
  if (threads > 1) {
    const int old = cv::getNumThreads();
    cv::setNumThreads(threads);
    cv::parallel_for_(cv::Range(0, n), work);
    t1 = now_ms();
    cv::parallel_for_(cv::Range(0, n), draw);
    cv::setNumThreads(old);
  } else {
    work(cv::Range(0, n));
    t1 = now_ms();
    draw(cv::Range(0, n));
  }
  t2 = now_ms();
  Compositor comp;
  comp.reset(req.view.width, req.view.height);
  RenderStats s;
  for (const Fragment& f : frags) {
    comp.add(f);
    s.fragment_pixels += f.pixel_count();
    s.contributing += f.empty() ? 0 : 1;
  }
  cv::Mat out;
  comp.resolve(out);
  const double t3 = now_ms();
  s.plan_ms = t1 - t0;
  s.render_ms = t2 - t1;
  s.composite_ms = t3 - t2;
  if (stats) *stats = s;
  return out;
}

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

double focal_param_from_inverse_depth(const Rig& rig, double q) {
  if (!rig.has_focal_param)
    throw std::invalid_argument("rig '" + rig.name + "' has no light-slab focal parameter");
  return rig.focal_param_infinity - q * rig.focal_param_f_px;
}

std::vector<double> parse_number_list(const std::string& s, const std::string& what) {
  std::vector<double> out;
  size_t pos = 0;
  while (pos <= s.size()) {
    const size_t comma = s.find(',', pos);
    const std::string tok =
        s.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    size_t used = 0;
    double v = 0;
    try {
      v = std::stod(tok, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != tok.size() || !std::isfinite(v))
      throw std::invalid_argument(what + ": '" + tok + "' is not a number");
    out.push_back(v);
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return out;
}

FocalPlane parse_focal_plane(const std::string& s, const Rig& rig) {
  if (s == "infinity") return FocalPlane::infinity();
  if (s.rfind("depth:", 0) == 0)
    return plane_at_depth(rig, parse_number_list(s.substr(6), "focal depth")[0]);
  if (s.rfind("param:", 0) == 0)
    return plane_from_focal_param(rig, parse_number_list(s.substr(6), "focal parameter")[0]);
  if (s.rfind("plane:", 0) == 0) {
    const auto v = parse_number_list(s.substr(6), "focal plane");
    if (v.size() != 4) throw std::invalid_argument("focal plane needs nx,ny,nz,d");
    const FocalPlane p{{v[0], v[1], v[2]}, v[3]};
    if (p.at_infinity() && p.d == 0) throw std::invalid_argument("focal plane (0,0,0,0)");
    return p;
  }
  throw std::invalid_argument("focal plane '" + s +
                              "': use infinity, depth:Z, param:A or plane:nx,ny,nz,d");
}

VirtualView view_between_cameras(const Rig& rig, const cv::Vec3d& eye, int width, int height) {
  const cv::Vec2d X = rig.plane().to_plane(eye);
  const auto& pos = rig.plane_positions();
  int nearest = 0;
  for (size_t i = 1; i < pos.size(); ++i)
    if (cv::norm(pos[i] - X) < cv::norm(pos[nearest] - X)) nearest = static_cast<int>(i);
  Camera cam = rig.cameras[nearest];
  // Barycentric interpolation of the intrinsics over the simplex under X.
  for (const Simplex& s : rig.simplices()) {
    if (s.size == 1) break;
    std::array<double, 3> e{0, 0, 0};
    double sum = 0;
    bool in = true;
    for (int k = 0; k < s.size; ++k) {
      const Form2& f = rig.facets()[s.facet[k]];
      e[k] = s.sign[k] * f(X);
      if (e[k] < -1e-12 * rig.typical_spacing() * rig.typical_spacing()) in = false;
      sum += e[k];
    }
    if (!in || !(sum > 0)) continue;
    Intrinsics k{0, 0, 0, 0, 0, 0};
    for (int j = 0; j < s.size; ++j) {
      const Intrinsics& kj = rig.cameras[s.cams[j]].intrinsics;
      const double w = std::max(0.0, e[j]) / sum;
      k.fx += w * kj.fx, k.fy += w * kj.fy, k.cx += w * kj.cx, k.cy += w * kj.cy;
    }
    cam.intrinsics = k;
    break;
  }
  cam.intrinsics.fx = cam.intrinsics.fy = 0.5 * (cam.intrinsics.fx + cam.intrinsics.fy);
  cam.intrinsics.k1 = cam.intrinsics.k2 = 0;
  cam.extrinsics = Extrinsics::from_center(cam.extrinsics.R, eye);
  return VirtualView::from_camera(cam, width, height);
}

// ---------------------------------------------------------------------------
// Auto-focus

namespace {
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
  return r;
}

float bilinear(const cv::Mat& g, float u, float v) {
  const int x = static_cast<int>(u), y = static_cast<int>(v);
  const float fx = u - x, fy = v - y;
  const float* r0 = g.ptr<float>(y) + x;
  const float* r1 = g.ptr<float>(y + 1) + x;
  return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}
}  // namespace

AutofocusContext::AutofocusContext(const Rig& rig, const std::vector<cv::Mat>& images,
                                   AutofocusOptions opt)
    : rig_(&rig), opt_(opt) {
  if (images.size() != rig.cameras.size())
    throw std::invalid_argument("autofocus: image count does not match the rig");
  std::vector<double> widths;
  for (const Camera& c : rig.cameras) widths.push_back(c.width);
  const double w = median(widths);
  for (int width : {opt.coarse_width, opt.fine_width}) {
    const double scale = std::min(1.0, 1.5 * width / w);
    rigs_.push_back(scale_rig(rig, scale));
    std::vector<cv::Mat> gray(images.size());
    for (size_t i = 0; i < images.size(); ++i) {
      cv::Mat small, g;
      cv::resize(images[i], small,
                 cv::Size(rigs_.back().cameras[i].width, rigs_.back().cameras[i].height), 0, 0,
                 cv::INTER_AREA);
      cv::cvtColor(small, g, cv::COLOR_BGRA2GRAY);
      g.convertTo(gray[i], CV_32F);
    }
    gray_.push_back(std::move(gray));
  }
}

double AutofocusContext::sweep_cost(const ViewRequest& req_in, int width, double q,
                                    int level) const {
  const Rig& rig = rigs_[level];
  ViewRequest req = scaled_request(req_in, width);
  req.focal_plane = plane_at_inverse_depth(rig, q);
  const ViewGeometry g(rig, req);
  const int W = req.view.width, H = req.view.height;
  std::vector<float> s0(static_cast<size_t>(W) * H, 0), s1(s0.size(), 0), s2(s0.size(), 0);
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const FragmentPlan plan = plan_fragment(g, static_cast<int>(i));
    if (plan.empty()) continue;
    const Camera& cam = rig.cameras[i];
    const cv::Mat& img = gray_[level][i];
    for (const Run& run : plan.runs) {
      const FragmentPiece& pc = plan.pieces[run.piece];
      for (int x = run.x0; x < run.x1; ++x) {
        const double y = run.y;
        const double den = pc.weight_den(x, y);
        const double w = den != 0 ? std::clamp(pc.weight_num(x, y) / den, 0.0, 1.0) : 0.0;
        const cv::Vec3d h = pc.H * cv::Vec3d(x, y, 1.0);
        if (!(h[2] > 0) || !(w > 0)) continue;
        cv::Vec2d p(h[0] / h[2], h[1] / h[2]);
        if (cam.intrinsics.has_distortion()) p = cam.distort_pixel(p);
        if (!(p[0] >= 0 && p[1] >= 0 && p[0] < cam.width - 1 && p[1] < cam.height - 1)) continue;
        const float c = bilinear(img, static_cast<float>(p[0]), static_cast<float>(p[1]));
        const size_t k = static_cast<size_t>(run.y) * W + x;
        s0[k] += static_cast<float>(w);
        s1[k] += static_cast<float>(w) * c;
        s2[k] += static_cast<float>(w) * c * c;
      }
    }
  }
  const double cap = opt_.truncate * opt_.truncate;
  double sum = 0;
  size_t count = 0;
  for (size_t k = 0; k < s0.size(); ++k) {
    if (s0[k] < 0.9f) continue;  // most of the aperture must see the point
    const double m = s1[k] / s0[k];
    const double var = std::max(0.0, s2[k] / s0[k] - m * m);
    sum += std::min(var, cap);
    ++count;
  }
  return count ? sum / count : cap;
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
  const int fb = static_cast<int>(std::min_element(fc.begin(), fc.end()) - fc.begin());
  double q = fq[fb];
  if (fb > 0 && fb < nf - 1) {
    const double a = fc[fb - 1], b = fc[fb], c = fc[fb + 1];
    const double denom = a - 2 * b + c;
    if (denom > 0) q += 0.5 * (a - c) / denom * (fq[1] - fq[0]);
  }
  res.inverse_depth = std::max(0.0, q);
  res.plane = plane_at_inverse_depth(*rig_, res.inverse_depth);
  return res;
}

cv::Mat camera_view_image(const Camera& cam, const cv::Mat& image, int width, int height) {
  const double s = static_cast<double>(height) / cam.height;
  const double sw = cam.width * s, crop = 0.5 * (sw - width);
  if (std::abs(sw - std::round(sw)) > 1e-9 || std::abs(crop - std::round(crop)) > 1e-9)
    throw std::invalid_argument("camera_view_image: " + std::to_string(width) + "x" +
                                std::to_string(height) + " is not a whole-pixel crop of camera " +
                                std::to_string(cam.id) + "'s image");
  cv::Mat scaled;
  cv::resize(image, scaled, cv::Size(static_cast<int>(std::lround(sw)), height), 0, 0,
             cv::INTER_AREA);
  cv::Mat out(height, width, image.type(), cv::Scalar::all(0));
  const int c = static_cast<int>(std::lround(crop));
  const int x0 = std::max(0, c), x1 = std::min(scaled.cols, c + width);
  if (x1 > x0) scaled.colRange(x0, x1).copyTo(out.colRange(x0 - c, x1 - c));
  return out;
}

// ---------------------------------------------------------------------------
// Metrics

namespace {
cv::Mat colour(const cv::Mat& m, int border) {
  if (m.empty() || m.depth() != CV_8U) throw std::invalid_argument("metric: 8-bit image expected");
  const cv::Rect roi(border, border, m.cols - 2 * border, m.rows - 2 * border);
  if (roi.width <= 0 || roi.height <= 0) throw std::invalid_argument("metric: border too large");
  cv::Mat c = m(roi);
  if (c.channels() == 4) cv::cvtColor(c, c, cv::COLOR_BGRA2BGR);
  return c;
}
}  // namespace

double psnr(const cv::Mat& a, const cv::Mat& b, int border) {
  if (a.size() != b.size()) throw std::invalid_argument("psnr: image sizes differ");
  return cv::PSNR(colour(a, border), colour(b, border));
}

double ssim(const cv::Mat& a, const cv::Mat& b, int border) {
  if (a.size() != b.size()) throw std::invalid_argument("ssim: image sizes differ");
  const cv::Scalar s =
      cv::quality::QualitySSIM::compute(colour(a, border), colour(b, border), cv::noArray());
  return (s[0] + s[1] + s[2]) / 3.0;
}

}  // namespace lf
