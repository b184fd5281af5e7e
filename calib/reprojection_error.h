// Ceres cost functors of the camera model (lf/geometry/camera.h; the projection itself
// is lf/geometry/projection.h, shared with lf::Camera::project), in the shape of
// Ceres' examples/snavely_reprojection_error.h: a templated operator() and a
// Create() factory returning an AutoDiffCostFunction.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/rotation.h>

#include "lf/geometry/projection.h"

namespace lf::calib {

// Pixel residual of one observation (u, v): predicted - observed, pixels.
// Parameter blocks: pose = angle-axis (3, world -> camera rotation) + t (3,
// rig units); intrinsics = f (fx = fy, pixels), k1, k2; principal point
// cx, cy (pixels); point X (3, world, rig units).
struct ReprojectionError {
  ReprojectionError(double u, double v) : u(u), v(v) {}

  template <typename T>
  bool operator()(const T* pose, const T* intr, const T* pp, const T* X, T* r) const {
    T P[3];
    ceres::AngleAxisRotatePoint(pose, X, P);
    P[0] += pose[3], P[1] += pose[4], P[2] += pose[5];
    T uv[2];
    project_camera_point(P, intr[0], intr[0], pp[0], pp[1], intr[1], intr[2], uv);
    r[0] = uv[0] - T(u);
    r[1] = uv[1] - T(v);
    return true;
  }

  static ceres::CostFunction* Create(double u, double v) {
    return new ceres::AutoDiffCostFunction<ReprojectionError, 2, 6, 3, 2, 3>(
        new ReprojectionError(u, v));
  }

  double u, v;
};

// The same model in the Bundle Adjustment in the Large layout (one 9-block
// per camera: angle-axis, t, f, k1, k2; principal point at the origin;
// `sign` = -1 for BAL's cameras, which look down -z: x = -P0 / P2).
struct BalReprojectionError {
  BalReprojectionError(double u, double v, double sign) : u(u), v(v), sign(sign) {}

  template <typename T>
  bool operator()(const T* camera, const T* X, T* r) const {
    T P[3];
    ceres::AngleAxisRotatePoint(camera, X, P);
    P[0] += camera[3], P[1] += camera[4], P[2] += camera[5];
    P[0] *= T(sign), P[1] *= T(sign);
    T uv[2];
    const T zero(0);
    project_camera_point(P, camera[6], camera[6], zero, zero, camera[7], camera[8], uv);
    r[0] = uv[0] - T(u);
    r[1] = uv[1] - T(v);
    return true;
  }

  static ceres::CostFunction* Create(double u, double v, bool bal_sign) {
    return new ceres::AutoDiffCostFunction<BalReprojectionError, 2, 9, 3>(
        new BalReprojectionError(u, v, bal_sign ? -1.0 : 1.0));
  }

  double u, v, sign;
};

}  // namespace lf::calib
