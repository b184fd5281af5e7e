#include "lf/focus/focus.h"

#include <algorithm>
#include <cmath>
#if (defined(__x86_64__) || defined(_M_X64)) && !defined(LF_NO_SIMD)
#include <immintrin.h>
#endif
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "lf/geometry/rig_ops.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"

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

// One run of a camera's pixels through one fragment piece: the homography's
// rows and the aperture weight's numerator and denominator as affine
// functions of x along the row (float), and the grey image's sampling limits
// (bilinear taps inside: u < umax = cols - 1, v < vmax = rows - 1).
struct RunTerms {
  float xa, xb, ya, yb, za, zb, na, nb, da, db;
  const float* img;
  int stride;  // floats per image row
  float umax, vmax;
};

// Adds each pixel's aperture weight w, w c and w c^2 (c the camera's
// bilinear sample) to a0, a1, a2 for x = x0 .. x0 + n - 1: the reference
// that accumulate_run_avx2 reproduces. Without a branch on the pixel (one the
// camera does not see is sampled at (0, 0) with weight 0), as the vector loop
// must be; the terms are copied to locals, which the writes cannot alias.
void accumulate_run(const RunTerms& k, int x0, int n, float* a0, float* a1, float* a2) {
  const float xa = k.xa, xb = k.xb, ya = k.ya, yb = k.yb, za = k.za, zb = k.zb;
  const float na = k.na, nb = k.nb, da = k.da, db = k.db, umax = k.umax, vmax = k.vmax;
  const float* img = k.img;
  const int stride = k.stride;
  for (int j = 0; j < n; ++j) {
    const float x = static_cast<float>(x0 + j);
    const float den = da * x + db, hz = za * x + zb;
    const float w = std::min(1.0f, (na * x + nb) / den);
    const float iz = 1.0f / hz;
    const float u = (xa * x + xb) * iz, v = (ya * x + yb) * iz;
    const bool ok = (den != 0.0f) & (hz > 0.0f) & (w > 0.0f) & (u >= 0.0f) & (v >= 0.0f) &
                    (u < umax) & (v < vmax);
    const float uu = ok ? u : 0.0f, vv = ok ? v : 0.0f, ww = ok ? w : 0.0f;
    const int iu = static_cast<int>(uu), iv = static_cast<int>(vv);
    const float fu = uu - static_cast<float>(iu), fv = vv - static_cast<float>(iv);
    const int i = iv * stride + iu;
    const float c = (1 - fv) * ((1 - fu) * img[i] + fu * img[i + 1]) +
                    fv * ((1 - fu) * img[i + stride] + fu * img[i + stride + 1]);
    a0[j] += ww;
    a1[j] += ww * c;
    a2[j] += ww * c * c;
  }
}

#if (defined(__x86_64__) || defined(_M_X64)) && !defined(LF_NO_SIMD)
#define LF_PC_SIMD 1
// Eight pixels at a time, the same operations in the same order as the
// scalar body (no fused multiply-add), so the sums are identical; the
// scalar body finishes the run.
__attribute__((target("avx2"))) void accumulate_run_avx2(const RunTerms& k, int x0, int n,
                                                         float* a0, float* a1, float* a2) {
  const __m256 xa = _mm256_set1_ps(k.xa), xb = _mm256_set1_ps(k.xb), ya = _mm256_set1_ps(k.ya),
               yb = _mm256_set1_ps(k.yb), za = _mm256_set1_ps(k.za), zb = _mm256_set1_ps(k.zb),
               na = _mm256_set1_ps(k.na), nb = _mm256_set1_ps(k.nb), da = _mm256_set1_ps(k.da),
               db = _mm256_set1_ps(k.db), umax = _mm256_set1_ps(k.umax),
               vmax = _mm256_set1_ps(k.vmax), one = _mm256_set1_ps(1.0f),
               zero = _mm256_setzero_ps(), lanes = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i stride = _mm256_set1_epi32(k.stride);
  const float* img = k.img;
  int j = 0;
  for (; j + 8 <= n; j += 8) {
    const __m256 x = _mm256_add_ps(_mm256_set1_ps(static_cast<float>(x0 + j)), lanes);
    const __m256 den = _mm256_add_ps(_mm256_mul_ps(da, x), db);
    const __m256 hz = _mm256_add_ps(_mm256_mul_ps(za, x), zb);
    const __m256 w =
        _mm256_min_ps(_mm256_div_ps(_mm256_add_ps(_mm256_mul_ps(na, x), nb), den), one);
    const __m256 iz = _mm256_div_ps(one, hz);
    const __m256 u = _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(xa, x), xb), iz);
    const __m256 v = _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(ya, x), yb), iz);
    __m256 ok =
        _mm256_and_ps(_mm256_cmp_ps(den, zero, _CMP_NEQ_UQ), _mm256_cmp_ps(hz, zero, _CMP_GT_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(w, zero, _CMP_GT_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(u, zero, _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(v, zero, _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(u, umax, _CMP_LT_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(v, vmax, _CMP_LT_OQ));
    const __m256 uu = _mm256_and_ps(ok, u), vv = _mm256_and_ps(ok, v), ww = _mm256_and_ps(ok, w);
    const __m256i iu = _mm256_cvttps_epi32(uu), iv = _mm256_cvttps_epi32(vv);
    const __m256 fu = _mm256_sub_ps(uu, _mm256_cvtepi32_ps(iu)),
                 fv = _mm256_sub_ps(vv, _mm256_cvtepi32_ps(iv));
    const __m256i i = _mm256_add_epi32(_mm256_mullo_epi32(iv, stride), iu);
    const __m256 p00 = _mm256_i32gather_ps(img, i, 4), p01 = _mm256_i32gather_ps(img + 1, i, 4),
                 p10 = _mm256_i32gather_ps(img + k.stride, i, 4),
                 p11 = _mm256_i32gather_ps(img + k.stride + 1, i, 4);
    const __m256 gu = _mm256_sub_ps(one, fu), gv = _mm256_sub_ps(one, fv);
    const __m256 top = _mm256_add_ps(_mm256_mul_ps(gu, p00), _mm256_mul_ps(fu, p01));
    const __m256 bot = _mm256_add_ps(_mm256_mul_ps(gu, p10), _mm256_mul_ps(fu, p11));
    const __m256 c = _mm256_add_ps(_mm256_mul_ps(gv, top), _mm256_mul_ps(fv, bot));
    const __m256 wc = _mm256_mul_ps(ww, c);
    _mm256_storeu_ps(a0 + j, _mm256_add_ps(_mm256_loadu_ps(a0 + j), ww));
    _mm256_storeu_ps(a1 + j, _mm256_add_ps(_mm256_loadu_ps(a1 + j), wc));
    _mm256_storeu_ps(a2 + j, _mm256_add_ps(_mm256_loadu_ps(a2 + j), _mm256_mul_ps(wc, c)));
  }
  accumulate_run(k, x0 + j, n - j, a0 + j, a1 + j, a2 + j);
}
#endif
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
                       double q, double truncate, cv::Mat& cost, ConsistencyPlans* reuse,
                       Kernel kernel) {
  if (gray.size() != rig.cameras.size())
    throw std::invalid_argument("photo consistency: " + std::to_string(gray.size()) +
                                " grey images for " + std::to_string(rig.cameras.size()) +
                                " cameras");
  for (size_t i = 0; i < gray.size(); ++i)
    if (gray[i].type() != CV_32F || gray[i].cols != rig.cameras[i].width ||
        gray[i].rows != rig.cameras[i].height)
      throw std::invalid_argument("photo consistency: camera " + std::to_string(rig.cameras[i].id) +
                                  "'s grey image is not CV_32F of its size");
  if (kernel == Kernel::kBest) kernel = best_kernel();
  if (!kernel_available(kernel))
    throw std::invalid_argument(std::string("photo consistency: the ") + kernel_name(kernel) +
                                " kernel is not available on this CPU or build");
  ViewRequest req = req_in;
  req.surface = {};
  req.focal_plane = plane_at_inverse_depth(rig, q);
  const ViewGeometry g(rig, req);
  const int W = req.view.width, H = req.view.height;
  std::vector<float> s0(static_cast<size_t>(W) * H, 0), s1(s0.size(), 0), s2(s0.size(), 0);
  auto run_kernel = accumulate_run;
#ifdef LF_PC_SIMD
  if (kernel == Kernel::kAvx2 || kernel == Kernel::kAvx512) run_kernel = accumulate_run_avx2;
#endif
  if (reuse && reuse->plans.size() != rig.cameras.size()) {
    reuse->plans.assign(rig.cameras.size(), FragmentPlan{});
    reuse->reusable.assign(rig.cameras.size(), false);
  }
  FragmentPlan fresh;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const int index = static_cast<int>(i);
    const FragmentPlan* pp = &fresh;
    if (!reuse) {
      fresh = plan_fragment(g, index);
    } else if (reuse->reusable[i] && plan_is_plane_free(g, index)) {
      aim_plan(g, reuse->plans[i]);
      pp = &reuse->plans[i];
    } else {
      reuse->plans[i] = plan_fragment(g, index);
      reuse->reusable[i] = plan_is_plane_free(g, index);
      pp = &reuse->plans[i];
    }
    const FragmentPlan& plan = *pp;
    if (plan.empty()) continue;
    const Camera& cam = rig.cameras[i];
    const cv::Mat& img = gray[i];
    for (const Run& run : plan.runs) {
      const FragmentPiece& pc = plan.pieces[run.piece];
      const size_t at = static_cast<size_t>(run.y) * W + run.x0;
      // The weight's terms and the homography are affine in x along a row.
      const double y = run.y;
      const cv::Matx33d& Hm = pc.H;
      if (!cam.intrinsics.has_distortion()) {
        const auto f = [](double v) { return static_cast<float>(v); };
        const RunTerms k{f(Hm(0, 0)),        f(Hm(0, 1) * y + Hm(0, 2)),
                         f(Hm(1, 0)),        f(Hm(1, 1) * y + Hm(1, 2)),
                         f(Hm(2, 0)),        f(Hm(2, 1) * y + Hm(2, 2)),
                         f(pc.weight_num.a), f(pc.weight_num.b * y + pc.weight_num.c),
                         f(pc.weight_den.a), f(pc.weight_den.b * y + pc.weight_den.c),
                         img.ptr<float>(),   static_cast<int>(img.step1()),
                         f(img.cols - 1),    f(img.rows - 1)};
        run_kernel(k, run.x0, run.x1 - run.x0, &s0[at], &s1[at], &s2[at]);
        continue;
      }
      const double num_y = pc.weight_num.b * y + pc.weight_num.c,
                   den_y = pc.weight_den.b * y + pc.weight_den.c;
      const double h0_y = Hm(0, 1) * y + Hm(0, 2), h1_y = Hm(1, 1) * y + Hm(1, 2),
                   h2_y = Hm(2, 1) * y + Hm(2, 2);
      for (int x = run.x0; x < run.x1; ++x) {
        const double den = pc.weight_den.a * x + den_y;
        const double w = den != 0 ? std::clamp((pc.weight_num.a * x + num_y) / den, 0.0, 1.0) : 0.0;
        const double hz = Hm(2, 0) * x + h2_y;
        if (!(hz > 0) || !(w > 0)) continue;
        const cv::Vec2d p =
            cam.distort_pixel(cv::Vec2d((Hm(0, 0) * x + h0_y) / hz, (Hm(1, 0) * x + h1_y) / hz));
        // Checked after rounding to float: 238.9999999 becomes 239.0f, whose
        // bilinear neighbour would be a row past the image.
        const float u = static_cast<float>(p[0]), v = static_cast<float>(p[1]);
        if (!(u >= 0 && v >= 0 && u < img.cols - 1 && v < img.rows - 1)) continue;
        const float c = bilinear(img, u, v);
        const size_t j = at + (x - run.x0);
        s0[j] += static_cast<float>(w);
        s1[j] += static_cast<float>(w) * c;
        s2[j] += static_cast<float>(w) * c * c;
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

double AutofocusContext::sweep_cost(const ViewRequest& req, int width, double q, int level,
                                    ConsistencyPlans* plans) const {
  cv::Mat cost;
  photo_consistency(levels_[level].rig, levels_[level].gray, scaled_request(req, width), q,
                    opt_.truncate, cost, plans);
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
  ConsistencyPlans coarse_plans, fine_plans;  // each camera planned once per pass
  for (int k = 0; k < nc; ++k) {
    qs[k] = q_max * k / (nc - 1);
    cost[k] = sweep_cost(req, std::min(opt_.coarse_width, req.view.width), qs[k], 0, &coarse_plans);
    res.curve.emplace_back(qs[k], cost[k]);
  }
  const int kb = static_cast<int>(std::min_element(cost.begin(), cost.end()) - cost.begin());
  const double lo = qs[std::max(0, kb - 1)], hi = qs[std::min(nc - 1, kb + 1)];
  const int nf = std::max(3, opt_.fine_steps);
  std::vector<double> fq(nf), fc(nf);
  for (int k = 0; k < nf; ++k) {
    fq[k] = lo + (hi - lo) * k / (nf - 1);
    fc[k] = sweep_cost(req, std::min(opt_.fine_width, req.view.width), fq[k], 1, &fine_plans);
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
