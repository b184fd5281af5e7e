// The camera model's projection (lf/geometry/camera.h: pinhole + two radial terms,
// Yang et al. 2002, 4.4.2), written once as templates so that the same code
// serves lf::Camera (T = double) and the calibration's Ceres cost functors
// (T = ceres::Jet, automatic differentiation; calib/reprojection_error.h),
// and the distortion's inverse.
#pragma once

#include <opencv2/core.hpp>
#include <optional>

#include "lf/geometry/camera.h"

namespace lf {

// Radial distortion factor 1 + k1 r^2 + k2 r^4 at squared normalized radius r2.
template <typename T>
T distortion_factor(const T& r2, const T& k1, const T& k2) {
  return T(1) + r2 * (k1 + k2 * r2);
}

// Camera-frame point Xc (x right, y down, z forward; Xc[2] != 0) -> distorted
// pixel uv (pixel-centre origin): u = fx d x + cx, v = fy d y + cy with
// (x, y) = (Xc0, Xc1) / Xc2 and d = distortion_factor(x^2 + y^2).
template <typename T>
void project_camera_point(const T* Xc, const T& fx, const T& fy, const T& cx, const T& cy,
                          const T& k1, const T& k2, T* uv) {
  const T x = Xc[0] / Xc[2], y = Xc[1] / Xc[2];
  const T d = distortion_factor(T(x * x + y * y), k1, k2);
  uv[0] = fx * d * x + cx;
  uv[1] = fy * d * y + cy;
}

// Applies the radial distortion to normalized coordinates.
cv::Vec2d distort_normalized(const Intrinsics& K, const cv::Vec2d& xy);
// Inverts distort_normalized by Newton's method. Returns nullopt where the
// model is not invertible (past the radius where r_d(r) stops increasing) or
// the iteration does not converge; never returns NaN.
std::optional<cv::Vec2d> undistort_normalized(const Intrinsics& K, const cv::Vec2d& xy_d);
// Undistorted normalized radius beyond which the radial model folds back
// (r_d'(r) <= 0); +inf when it never does. Points beyond it are not imaged.
double distortion_fold_radius(const Intrinsics& K);

}  // namespace lf
