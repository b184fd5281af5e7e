// Pinhole camera with two-term radial distortion: the camera model of
// Yang et al., "A Real-Time Distributed Light Field Camera" (EGWR 2002),
// Section 4.4.2 (focal length, principal point, two radial terms), in the
// conventions of OpenCV's calibration module.
//
// Frames and units
//  * World ("rig") frame: right-handed, any length unit (the rig's unit).
//  * Camera frame: x right, y down, z forward (optical axis), same length unit.
//  * Extrinsics map world -> camera: X_cam = R * X_world + t. The camera centre
//    in the world is C = -R^T t.
//  * Pixel frame: x right, y down, origin at the CENTRE of the top-left pixel,
//    so pixel (i, j) covers [i-0.5, i+0.5] x [j-0.5, j+0.5]. Units: pixels.
//  * Normalized image coordinates: (X/Z, Y/Z) of a camera-frame point.
//  * Distortion (Brown radial, k1 and k2 only): with r^2 = x^2 + y^2,
//    x_d = x (1 + k1 r^2 + k2 r^4), likewise y; then u = fx x_d + cx,
//    v = fy y_d + cy.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>

namespace lf {

struct Intrinsics {
  double fx = 1.0;  // focal length, pixels
  double fy = 1.0;  // focal length, pixels
  double cx = 0.0;  // principal point, pixels (pixel-centre origin)
  double cy = 0.0;
  double k1 = 0.0;  // radial distortion, dimensionless
  double k2 = 0.0;

  bool has_distortion() const { return k1 != 0.0 || k2 != 0.0; }
  // 3x3 calibration matrix K (no skew).
  cv::Matx33d K() const { return {fx, 0, cx, 0, fy, cy, 0, 0, 1}; }
  // Intrinsics of the same camera after resizing its image by `scale`
  // (pixel centres move as (p + 0.5) * scale - 0.5).
  Intrinsics scaled(double scale) const;
};

struct Extrinsics {
  cv::Matx33d R = cv::Matx33d::eye();  // world -> camera rotation
  cv::Vec3d t = {0, 0, 0};             // world -> camera translation (rig units)

  cv::Vec3d center() const { return -(R.t() * t); }
  // Builds extrinsics from a camera centre and a camera->world rotation's
  // inverse (R world->camera): t = -R C.
  static Extrinsics from_center(const cv::Matx33d& R_world_to_cam, const cv::Vec3d& C);
};

struct Camera {
  int id = 0;        // stable camera id (the id carried by fragments)
  std::string name;  // human-readable, e.g. "r03c05"
  int width = 0;     // image size, pixels
  int height = 0;
  Intrinsics intrinsics;
  Extrinsics extrinsics;
  std::string image;  // optional image file (absolute, or relative to the rig file)
  // Colour correction (paper 4.4.3): corrected = A * [r g b]^T + b, 8-bit
  // levels, applied to the camera's frames before warping. Row-major 3x4
  // [A | b]; identity by default. Channel order is the frames' (RGB in the
  // GStreamer elements).
  cv::Matx34d colour = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  bool has_colour_correction() const {
    return colour != cv::Matx34d(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0);
  }

  cv::Vec3d center() const { return extrinsics.center(); }
  // Optical axis (camera +z) in world coordinates.
  cv::Vec3d forward() const;

  // World point -> distorted pixel. nullopt if the point is not strictly in
  // front of the camera (Z <= 0).
  std::optional<cv::Vec2d> project(const cv::Vec3d& X_world) const;
  // Distorted pixel -> unit ray direction in world coordinates (from the
  // camera centre). nullopt where the distortion cannot be inverted.
  std::optional<cv::Vec3d> unproject(const cv::Vec2d& pixel) const;
  // Pixel <-> normalized, both with distortion applied/removed.
  cv::Vec2d distort_pixel(const cv::Vec2d& undistorted_pixel) const;
  std::optional<cv::Vec2d> undistort_pixel(const cv::Vec2d& distorted_pixel) const;
};

}  // namespace lf
