#include "lf/geometry/camera.h"

#include <cmath>

#include "lf/geometry/projection.h"

namespace lf {

Intrinsics Intrinsics::scaled(double s) const {
  Intrinsics k = *this;
  k.fx = fx * s;
  k.fy = fy * s;
  k.cx = (cx + 0.5) * s - 0.5;
  k.cy = (cy + 0.5) * s - 0.5;
  return k;
}

Extrinsics Extrinsics::from_center(const cv::Matx33d& R, const cv::Vec3d& C) {
  Extrinsics e;
  e.R = R;
  e.t = -(R * C);
  return e;
}

cv::Vec3d Camera::forward() const {
  return {extrinsics.R(2, 0), extrinsics.R(2, 1), extrinsics.R(2, 2)};
}

std::optional<cv::Vec2d> Camera::project(const cv::Vec3d& X) const {
  const cv::Vec3d Xc = extrinsics.R * X + extrinsics.t;
  if (!(Xc[2] > 0.0)) return std::nullopt;
  const Intrinsics& K = intrinsics;
  cv::Vec2d uv;
  project_camera_point(Xc.val, K.fx, K.fy, K.cx, K.cy, K.k1, K.k2, uv.val);
  return uv;
}

std::optional<cv::Vec3d> Camera::unproject(const cv::Vec2d& p) const {
  const cv::Vec2d xd((p[0] - intrinsics.cx) / intrinsics.fx,
                     (p[1] - intrinsics.cy) / intrinsics.fy);
  const auto x = undistort_normalized(intrinsics, xd);
  if (!x) return std::nullopt;
  const cv::Vec3d d = extrinsics.R.t() * cv::Vec3d((*x)[0], (*x)[1], 1.0);
  return d / cv::norm(d);
}

cv::Vec2d Camera::distort_pixel(const cv::Vec2d& p) const {
  const cv::Vec2d x((p[0] - intrinsics.cx) / intrinsics.fx, (p[1] - intrinsics.cy) / intrinsics.fy);
  const cv::Vec2d xd = distort_normalized(intrinsics, x);
  return {intrinsics.fx * xd[0] + intrinsics.cx, intrinsics.fy * xd[1] + intrinsics.cy};
}

std::optional<cv::Vec2d> Camera::undistort_pixel(const cv::Vec2d& p) const {
  const cv::Vec2d xd((p[0] - intrinsics.cx) / intrinsics.fx,
                     (p[1] - intrinsics.cy) / intrinsics.fy);
  const auto x = undistort_normalized(intrinsics, xd);
  if (!x) return std::nullopt;
  return cv::Vec2d(intrinsics.fx * (*x)[0] + intrinsics.cx,
                   intrinsics.fy * (*x)[1] + intrinsics.cy);
}

}  // namespace lf
