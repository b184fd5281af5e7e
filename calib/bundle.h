// Bundle adjustment with Ceres (Triggs et al. 2000; the paper's step 4 of
// 4.4.2: one nonlinear optimisation over every camera's pose and intrinsics
// and the 3-D points). Camera model: the paper's (and the BAL format's,
// Agarwal et al., "Bundle Adjustment in the Large", ECCV 2010): rotation as an
// angle-axis vector (world -> camera), translation, focal length f, radial
// terms k1, k2 on the normalised point, no skew, principal point at the
// image centre (observations are relative to it).
//   P = R X + t;  p = -P.xy / P.z (BAL) or P.xy / P.z (OpenCV convention);
//   x = f (1 + k1 |p|^2 + k2 |p|^4) p
#pragma once

#include <istream>
#include <string>
#include <vector>

namespace lf::calib {

struct BundleProblem {
  int num_cameras = 0, num_points = 0;
  std::vector<double> cameras;  // 9 per camera: angle-axis (3), t (3), f, k1, k2
  std::vector<double> points;   // 3 per point
  struct Observation {
    int camera, point;
    double x, y;  // pixels relative to the principal point
  };
  std::vector<Observation> observations;
  bool bal_sign = true;  // BAL's p = -P.xy / P.z (cameras look down -z)
};

// Reads a BAL problem file. Throws std::runtime_error naming the file, the
// line and what is wrong (bad header, index out of range, non-finite value,
// truncation).
BundleProblem read_bal(const std::string& path);
// The same from a stream; `name` names it in errors.
BundleProblem read_bal(std::istream& in, const std::string& name);

struct BundleOptions {
  int max_iterations = 100;
  double huber_px = 0;  // > 0: Huber loss with this scale (pixels); 0: squared loss
  int threads = 1;
  bool progress = false;  // Ceres' per-iteration lines on stdout
};

struct BundleReport {
  double initial_cost = 0, final_cost = 0;      // Ceres' 0.5 * sum of squared residuals
  double initial_rms_px = 0, final_rms_px = 0;  // RMS per residual coordinate
  int iterations = 0;
  bool converged = false;
  std::string summary;  // Ceres' brief report
};

// Refines cameras and points in place: Levenberg-Marquardt, sparse Schur
// complement with the points eliminated first.
BundleReport bundle_adjust(BundleProblem& problem, const BundleOptions& options = {});

}  // namespace lf::calib
