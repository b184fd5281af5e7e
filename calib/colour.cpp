#include "calib/colour.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace lf::calib {

cv::Vec3d srgb_to_lab(const cv::Vec3d& rgb) {
  auto lin = [](double v) {
    v = std::clamp(v / 255.0, 0.0, 1.0);
    return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
  };
  const double r = lin(rgb[0]), g = lin(rgb[1]), b = lin(rgb[2]);
  const double X = 0.4124564 * r + 0.3575761 * g + 0.1804375 * b;
  const double Y = 0.2126729 * r + 0.7151522 * g + 0.0721750 * b;
  const double Z = 0.0193339 * r + 0.1191920 * g + 0.9503041 * b;
  auto f = [](double t) {
    return t > 216.0 / 24389 ? std::cbrt(t) : (24389.0 / 27 * t + 16) / 116;
  };
  const double fx = f(X / 0.95047), fy = f(Y), fz = f(Z / 1.08883);
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

double delta_e2000(const cv::Vec3d& l1, const cv::Vec3d& l2) {
  // Sharma, Wu, Dalal (2005), kL = kC = kH = 1.
  const double deg = CV_PI / 180;
  const double C1 = std::hypot(l1[1], l1[2]), C2 = std::hypot(l2[1], l2[2]);
  const double Cm = 0.5 * (C1 + C2), Cm7 = std::pow(Cm, 7);
  const double G = 0.5 * (1 - std::sqrt(Cm7 / (Cm7 + std::pow(25.0, 7))));
  const double a1 = (1 + G) * l1[1], a2 = (1 + G) * l2[1];
  const double c1 = std::hypot(a1, l1[2]), c2 = std::hypot(a2, l2[2]);
  auto hue = [](double b, double a) {
    if (a == 0 && b == 0) return 0.0;
    double h = std::atan2(b, a) * 180 / CV_PI;
    return h < 0 ? h + 360 : h;
  };
  const double h1 = hue(l1[2], a1), h2 = hue(l2[2], a2);
  const double dL = l2[0] - l1[0], dC = c2 - c1;
  double dh = 0;
  if (c1 * c2 != 0) {
    dh = h2 - h1;
    if (dh > 180) dh -= 360;
    if (dh < -180) dh += 360;
  }
  const double dH = 2 * std::sqrt(c1 * c2) * std::sin(dh / 2 * deg);
  const double Lm = 0.5 * (l1[0] + l2[0]), cm = 0.5 * (c1 + c2);
  double hm = h1 + h2;
  if (c1 * c2 != 0) {
    if (std::abs(h1 - h2) <= 180)
      hm = 0.5 * (h1 + h2);
    else
      hm = h1 + h2 < 360 ? 0.5 * (h1 + h2 + 360) : 0.5 * (h1 + h2 - 360);
  }
  const double T = 1 - 0.17 * std::cos((hm - 30) * deg) + 0.24 * std::cos(2 * hm * deg) +
                   0.32 * std::cos((3 * hm + 6) * deg) - 0.20 * std::cos((4 * hm - 63) * deg);
  const double dTheta = 30 * std::exp(-std::pow((hm - 275) / 25, 2));
  const double cm7 = std::pow(cm, 7);
  const double Rc = 2 * std::sqrt(cm7 / (cm7 + std::pow(25.0, 7)));
  const double Sl = 1 + 0.015 * (Lm - 50) * (Lm - 50) / std::sqrt(20 + (Lm - 50) * (Lm - 50));
  const double Sc = 1 + 0.045 * cm, Sh = 1 + 0.015 * cm * T;
  const double Rt = -std::sin(2 * dTheta * deg) * Rc;
  return std::sqrt(std::pow(dL / Sl, 2) + std::pow(dC / Sc, 2) + std::pow(dH / Sh, 2) +
                   Rt * (dC / Sc) * (dH / Sh));
}

namespace {

cv::Vec3d apply(const cv::Matx34d& M, const cv::Vec3d& c) {
  return {M(0, 0) * c[0] + M(0, 1) * c[1] + M(0, 2) * c[2] + M(0, 3),
          M(1, 0) * c[0] + M(1, 1) * c[1] + M(1, 2) * c[2] + M(1, 3),
          M(2, 0) * c[0] + M(2, 1) * c[1] + M(2, 2) * c[2] + M(2, 3)};
}

// Least-squares fit of camera colours `x` onto `y` over the samples in `use`.
cv::Matx34d fit(const std::vector<cv::Vec3d>& x, const std::vector<cv::Vec3d>& y,
                const std::vector<int>& use, ColourModel m) {
  cv::Matx34d M = cv::Matx34d::zeros();
  for (int ch = 0; ch < 3; ++ch) {
    const int n = static_cast<int>(use.size());
    const int p = m == ColourModel::kAffine ? 4 : 2;
    cv::Mat A(n, p, CV_64F), b(n, 1, CV_64F), sol;
    for (int k = 0; k < n; ++k) {
      const cv::Vec3d& c = x[use[k]];
      if (m == ColourModel::kAffine) {
        for (int j = 0; j < 3; ++j) A.at<double>(k, j) = c[j];
        A.at<double>(k, 3) = 1;
      } else {
        A.at<double>(k, 0) = c[ch];
        A.at<double>(k, 1) = 1;
      }
      b.at<double>(k) = y[use[k]][ch];
    }
    cv::solve(A, b, sol, cv::DECOMP_SVD);
    if (m == ColourModel::kAffine) {
      for (int j = 0; j < 4; ++j) M(ch, j) = sol.at<double>(j);
    } else {
      M(ch, ch) = sol.at<double>(0);
      M(ch, 3) = sol.at<double>(1);
    }
  }
  return M;
}

double mean_de(const std::vector<cv::Vec3d>& x, const std::vector<cv::Vec3d>& y,
               const cv::Matx34d& M) {
  double s = 0;
  for (size_t k = 0; k < x.size(); ++k)
    s += delta_e2000(srgb_to_lab(apply(M, x[k])), srgb_to_lab(y[k]));
  return s / x.size();
}

// Held-out mean deltaE: each sample predicted by the fit to the others.
double loo_de(const std::vector<cv::Vec3d>& x, const std::vector<cv::Vec3d>& y, ColourModel m) {
  double s = 0;
  for (size_t k = 0; k < x.size(); ++k) {
    std::vector<int> use;
    for (size_t j = 0; j < x.size(); ++j)
      if (j != k) use.push_back(static_cast<int>(j));
    const cv::Matx34d M = fit(x, y, use, m);
    s += delta_e2000(srgb_to_lab(apply(M, x[k])), srgb_to_lab(y[k]));
  }
  return s / x.size();
}

}  // namespace

ArrayColour calibrate_colours(const std::vector<std::vector<cv::Vec3d>>& samples,
                              const std::vector<cv::Vec3d>& reference, const ColourOptions& o) {
  if (samples.empty()) throw std::invalid_argument("calibrate_colours: no cameras");
  const size_t n = samples[0].size();
  if (n < 8) throw std::invalid_argument("calibrate_colours: fewer than 8 samples");
  for (size_t c = 0; c < samples.size(); ++c)
    if (samples[c].size() != n)
      throw std::invalid_argument("calibrate_colours: camera " + std::to_string(c) + " has " +
                                  std::to_string(samples[c].size()) + " samples, camera 0 " +
                                  std::to_string(n));
  if (!reference.empty() && reference.size() != n)
    throw std::invalid_argument("calibrate_colours: reference has the wrong sample count");
  ArrayColour r;
  r.reference = reference;
  if (r.reference.empty()) {  // per-sample, per-channel median over the cameras
    r.reference.resize(n);
    for (size_t k = 0; k < n; ++k)
      for (int ch = 0; ch < 3; ++ch) {
        std::vector<double> v;
        for (const auto& cam : samples) v.push_back(cam[k][ch]);
        std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
        r.reference[k][ch] = v[v.size() / 2];
      }
  }
  std::ostringstream rep;
  rep << "| camera | model | mean deltaE2000 before | after | flag |\n|---|---|---|---|---|\n";
  std::vector<int> all(n);
  for (size_t k = 0; k < n; ++k) all[k] = static_cast<int>(k);
  double sb = 0, sa = 0;
  int good = 0;
  for (size_t c = 0; c < samples.size(); ++c) {
    CameraColour cc;
    const auto& x = samples[c];
    cc.delta_e_before = mean_de(x, r.reference, cv::Matx34d(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0));
    // A channel without range cannot be corrected.
    for (int ch = 0; ch < 3 && !cc.defective; ++ch) {
      double lo = 1e9, hi = -1e9;
      for (const auto& v : x) lo = std::min(lo, v[ch]), hi = std::max(hi, v[ch]);
      if (hi - lo < o.min_range)
        cc.defective = true, cc.why = "channel " + std::to_string(ch) + " spans only " +
                                      std::to_string(hi - lo) + " levels";
    }
    const bool enough = n >= 24;  // 12 parameters: at least twice as many samples
    const double loo_g = loo_de(x, r.reference, ColourModel::kGainOffset);
    const double loo_a = enough ? loo_de(x, r.reference, ColourModel::kAffine) : 1e9;
    cc.model =
        loo_a < (1 - o.affine_gain) * loo_g ? ColourModel::kAffine : ColourModel::kGainOffset;
    cc.correction = fit(x, r.reference, all, cc.model);
    cc.delta_e_after = mean_de(x, r.reference, cc.correction);
    if (!cc.defective) {
      for (int ch = 0; ch < 3; ++ch) {
        const double g = cc.correction(ch, ch), off = cc.correction(ch, 3);
        if (g < o.min_gain || g > o.max_gain) {
          cc.defective = true;
          cc.why = "channel " + std::to_string(ch) + " needs gain " + std::to_string(g);
          break;
        }
        if (std::abs(off) > o.max_offset) {
          cc.defective = true;
          cc.why = "channel " + std::to_string(ch) + " needs offset " + std::to_string(off);
          break;
        }
      }
    }
    if (!cc.defective && cc.delta_e_after > o.max_delta_e) {
      cc.defective = true;
      cc.why = "mean deltaE2000 " + std::to_string(cc.delta_e_after) + " after correction";
    }
    if (!cc.defective) {
      cc.why = std::string(cc.model == ColourModel::kAffine ? "affine 3x4" : "gain/offset") +
               " (held-out deltaE: gain/offset " + std::to_string(loo_g) +
               (enough ? ", affine " + std::to_string(loo_a) : std::string()) + ")";
      sb += cc.delta_e_before, sa += cc.delta_e_after, ++good;
    }
    rep << "| " << c << " | " << (cc.model == ColourModel::kAffine ? "affine" : "gain/offset")
        << " | " << cc.delta_e_before << " | " << cc.delta_e_after << " | "
        << (cc.defective ? "DEFECTIVE: " + cc.why : cc.why) << " |\n";
    r.cameras.push_back(cc);
  }
  r.mean_delta_e_before = good ? sb / good : 0;
  r.mean_delta_e_after = good ? sa / good : 0;
  rep << "mean deltaE2000 against the reference, " << good << " good cameras: before "
      << r.mean_delta_e_before << ", after " << r.mean_delta_e_after << "\n";
  r.report = rep.str();
  return r;
}

std::vector<std::vector<cv::Vec3d>> colour_samples_from_images(const Rig& rig,
                                                               const std::vector<cv::Mat>& images,
                                                               const FocalPlane& plane,
                                                               int reference, int grid) {
  if (images.size() != rig.cameras.size())
    throw std::invalid_argument("colour_samples_from_images: " + std::to_string(images.size()) +
                                " images for " + std::to_string(rig.cameras.size()) + " cameras");
  if (reference < 0 || reference >= static_cast<int>(rig.cameras.size()) || grid < 2)
    throw std::invalid_argument("colour_samples_from_images: bad reference or grid");
  for (size_t c = 0; c < images.size(); ++c)
    if (images[c].depth() != CV_8U || images[c].channels() < 3 ||
        images[c].cols != rig.cameras[c].width || images[c].rows != rig.cameras[c].height)
      throw std::invalid_argument("colour_samples_from_images: image " + std::to_string(c) +
                                  " is not 8-bit RGB(A) of the camera's size");
  auto mean5 = [](const cv::Mat& im, double x, double y, cv::Vec3d& out, double& spread) {
    const int xi = static_cast<int>(std::lround(x)), yi = static_cast<int>(std::lround(y));
    if (xi < 2 || yi < 2 || xi >= im.cols - 2 || yi >= im.rows - 2) return false;
    cv::Vec3d s(0, 0, 0), lo(255, 255, 255), hi(0, 0, 0);
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        const uint8_t* p = im.ptr<uint8_t>(yi + dy) + (xi + dx) * im.channels();
        for (int k = 0; k < 3; ++k)
          s[k] += p[k], lo[k] = std::min(lo[k], double(p[k])),
                        hi[k] = std::max(hi[k], double(p[k]));
      }
    out = s / 25.0;
    spread = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    return true;
  };
  const Camera& ref = rig.cameras[reference];
  std::vector<std::vector<cv::Vec3d>> samples(rig.cameras.size());
  for (int gy = 0; gy < grid; ++gy)
    for (int gx = 0; gx < grid; ++gx) {
      const double x = (gx + 0.5) * ref.width / grid, y = (gy + 0.5) * ref.height / grid;
      cv::Vec3d c0;
      double spread;
      if (!mean5(images[reference], x, y, c0, spread) || spread > 24) continue;
      const auto ray = ref.unproject({x, y});
      if (!ray) continue;
      // The scene point (or direction, at infinity) on the plane.
      cv::Vec3d X;
      bool direction = plane.at_infinity();
      if (!direction) {
        const double den = plane.n.dot(*ray);
        if (std::abs(den) < 1e-12) continue;
        const double t = -(plane.n.dot(ref.center()) + plane.d) / den;
        if (t <= 0) continue;
        X = ref.center() + t * (*ray);
      }
      std::vector<cv::Vec3d> got;
      for (size_t c = 0; c < rig.cameras.size(); ++c) {
        const Camera& cam = rig.cameras[c];
        const auto px = direction ? cam.project(cam.center() + 1e6 * (*ray)) : cam.project(X);
        cv::Vec3d col;
        double sp;
        if (!px || !mean5(images[c], (*px)[0], (*px)[1], col, sp)) break;
        got.push_back(col);
      }
      if (got.size() != rig.cameras.size()) continue;
      for (size_t c = 0; c < got.size(); ++c) samples[c].push_back(got[c]);
    }
  return samples;
}

}  // namespace lf::calib
