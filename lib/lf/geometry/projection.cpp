#include "lf/geometry/projection.h"

#include <cmath>

namespace lf {

cv::Vec2d distort_normalized(const Intrinsics& K, const cv::Vec2d& xy) {
  const double f = distortion_factor(xy[0] * xy[0] + xy[1] * xy[1], K.k1, K.k2);
  return {xy[0] * f, xy[1] * f};
}

namespace {
// r_d(r) = r (1 + k1 r^2 + k2 r^4); derivative 1 + 3 k1 r^2 + 5 k2 r^4.
double radial(double k1, double k2, double r) {
  return r * distortion_factor(r * r, k1, k2);
}
double radial_derivative(double k1, double k2, double r) {
  const double r2 = r * r;
  return 1.0 + r2 * (3.0 * k1 + 5.0 * k2 * r2);
}
// Smallest r > 0 where r_d'(r) = 0 (the model folds back there), or +inf.
double fold_radius(double k1, double k2) {
  // Solve 5 k2 s^2 + 3 k1 s + 1 = 0 for s = r^2 > 0.
  double best = INFINITY;
  if (k2 == 0.0) {
    if (k1 < 0.0) best = -1.0 / (3.0 * k1);
  } else {
    const double a = 5.0 * k2, b = 3.0 * k1, disc = b * b - 4.0 * a;
    if (disc >= 0.0) {
      const double sq = std::sqrt(disc);
      for (double s : {(-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)})
        if (s > 0.0 && s < best) best = s;
    }
  }
  return std::isfinite(best) ? std::sqrt(best) : INFINITY;
}
}  // namespace

double distortion_fold_radius(const Intrinsics& K) {
  return fold_radius(K.k1, K.k2);
}

std::optional<cv::Vec2d> undistort_normalized(const Intrinsics& K, const cv::Vec2d& xy_d) {
  if (!std::isfinite(xy_d[0]) || !std::isfinite(xy_d[1])) return std::nullopt;
  if (!K.has_distortion()) return xy_d;
  const double rd = std::hypot(xy_d[0], xy_d[1]);
  if (rd == 0.0) return cv::Vec2d(0, 0);
  const double r_fold = fold_radius(K.k1, K.k2);
  if (std::isfinite(r_fold) && rd >= radial(K.k1, K.k2, r_fold)) return std::nullopt;
  // Newton on the monotone branch r in [0, r_fold), started at r = rd.
  double r = std::isfinite(r_fold) ? std::min(rd, 0.999 * r_fold) : rd;
  for (int it = 0; it < 50; ++it) {
    const double g = radial(K.k1, K.k2, r) - rd;
    const double d = radial_derivative(K.k1, K.k2, r);
    if (!(d > 0.0)) return std::nullopt;
    double next = r - g / d;
    if (next < 0.0) next = 0.5 * r;
    if (std::isfinite(r_fold) && next >= r_fold) next = 0.5 * (r + r_fold);
    if (std::abs(next - r) <= 1e-15 * std::max(1.0, r)) {
      r = next;
      break;
    }
    r = next;
  }
  if (std::abs(radial(K.k1, K.k2, r) - rd) > 1e-10 * std::max(1.0, rd)) return std::nullopt;
  const double s = r / rd;
  return cv::Vec2d(xy_d[0] * s, xy_d[1] * s);
}

}  // namespace lf
