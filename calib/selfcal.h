// Point-light self-calibration of a camera array (Yang et al. 2002, 4.4.2,
// steps 2-4; after Svoboda et al., MultiCamSelfCal, PRESENCE 2005): a point
// light moved through the scene is seen by the cameras; from its tracks,
//  1. initial structure: all cameras share the intrinsics of the one camera
//     calibrated by Zhang's method; a widely separated pair gives the first
//     poses (essential matrix, RANSAC) and points; the other cameras are
//     registered by PnP (RANSAC) and points triangulated as they become
//     visible in two registered cameras;
//  2. refinement: a Ceres bundle adjustment over every camera's pose and
//     intrinsics (f, k1, k2; principal point held at the Zhang camera's)
//     and the points, Huber loss, then outliers flagged and removed and a
//     final least-squares solve; gauge: camera 0 fixed, scale fixed by one
//     translation component of the farthest camera, then scaled to `pitch`.
// The planar, parallel grid cannot determine the focal length from tracks
// alone ((f, Z) -> (s f, s Z) leaves observations unchanged): per-camera f,
// k1, k2 get priors at the Zhang camera's values. A shared, free focal length
// is accepted only if the data determines it (Ceres covariance); otherwise
// the result is marked degenerate. Degenerate data (too few points, the
// light swept in one plane, cameras seeing too few points) is reported, never
// returned as a confident rig.
//
// Frames: world = camera 0's frame scaled so the median distance between grid
// neighbours is `pitch` (rig units); pixels with (0, 0) at the centre of the
// top-left pixel; the lf::Camera model (fx = fy = f, k1, k2).
#pragma once

#include <string>
#include <vector>

#include "lf/geometry/rig.h"

namespace lf::calib {

struct PointObservation {
  int camera = 0;  // index into the cameras
  int point = 0;   // light position index (capture instant)
  cv::Vec2d pixel;
};

struct SelfCalOptions {
  double ransac_px = 2.0;         // RANSAC threshold (essential matrix, PnP)
  double huber_px = 1.0;          // robust loss scale in the first refinement
  double outlier_px = 0;          // residual norm above which an observation is an
                                  // outlier; 0: 5 x the robust sigma, at least 1.5 px
  double f_prior = 0.001;         // relative sigma of each camera's f around the Zhang
                                  // camera's; 0: one shared focal length, free
  double k_prior = 0.005;         // sigma of k1, k2 around the Zhang camera's
  double max_f_sigma = 0.003;     // shared free f: relative sigma above which the
                                  // focal length counts as undetermined
  double pin_principal_px = 1.0;  // a camera's principal point is freed when its sigma
                                  // (with all free) is below this; 0: always held
  double pitch = 1.0;             // median grid-neighbour distance in the output (rig units)
  int min_points = 30;            // fewer reconstructed points: degenerate
  int min_camera_points = 12;     // a camera seeing fewer: not registered
  int threads = 2;
};

struct SelfCalResult {
  Rig rig;                        // the input cameras with poses and intrinsics
  std::vector<cv::Vec3d> points;  // per light position (valid where point_valid)
  std::vector<bool> point_valid;
  std::vector<bool> outlier;        // per observation
  std::vector<double> residual_px;  // per observation: reprojection error norm (-1: unused)
  std::vector<bool> registered;     // per camera
  double rms_px = 0;                // RMS per residual coordinate, inliers
  double noise_floor_factor = 1;    // sqrt((N - p) / N) for the final solve
  std::vector<double> camera_rms_px;
  std::vector<int> camera_observations;
  // One standard deviation per camera (Ceres covariance; -1 if not computed),
  // in the solve's gauge (the initial pair's first camera fixed, scale fixed
  // by one translation component), so pose sigmas grow with the distance
  // from that camera:
  std::vector<double> f_sigma;                // f, pixels
  std::vector<double> principal_point_sigma;  // cx/cy (larger) with all free, px
  std::vector<cv::Vec3d> intrinsics_sigma;    // f (pixels), k1, k2
  std::vector<double> rotation_sigma_deg;     // of the rotation vector (norm of the 3 sigmas)
  std::vector<double> translation_sigma;      // of t, output units (norm of the 3 sigmas)
  bool degenerate = false;
  std::string degenerate_reason;
  std::vector<std::string> warnings;
  std::string log;  // progress and decisions, one line each
};

// cameras: the array's cameras (id, name, size; the rest is ignored);
// zhang_camera: index of the camera whose intrinsics `zhang` were measured by
// Zhang's method; observations: the tracks. Throws std::invalid_argument on
// malformed input (indices out of range, no observations).
SelfCalResult self_calibrate(const std::vector<Camera>& cameras, int zhang_camera,
                             const Intrinsics& zhang,
                             const std::vector<PointObservation>& observations,
                             const SelfCalOptions& options = {});

}  // namespace lf::calib
