// Synthetic point-light calibration data (tests and benchmarks): a rig with
// known poses and lenses, light positions, and the tracks its cameras would
// record (with noise, outliers and dropouts), for calib/selfcal.h.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "calib/selfcal.h"
#include "lf/geometry/rig.h"

namespace lf::calib {

// Synthetic point-light data for tests and benchmarks: the true rig, the
// light positions and the (noisy, partly outlying) observations.
struct SyntheticPointLight {
  Rig truth;
  std::vector<cv::Vec3d> lights;
  std::vector<PointObservation> observations;
  std::vector<bool> is_outlier;  // per observation, the truth
  Intrinsics zhang;              // the Zhang camera's (0) intrinsics as measured
};
struct SyntheticPointLightOptions {
  int rows = 8, cols = 8;
  double pitch = 0.1;  // metres
  double rot_jitter_deg = 2;
  int width = 640, height = 480;
  double f = 600, k1 = -0.12, k2 = 0.03;
  double f_spread = 0.002;  // relative spread of per-camera f (uniform +-)
  int lights = 200;
  double z_min = 1.5, z_max = 4.0;  // light depth range (metres); equal: one plane
  double noise_px = 0.3;
  double outlier_fraction = 0.03;
  double dropout = 0.05;          // observations missing at random
  double zhang_f_error = 0.0005;  // relative error of the Zhang camera's f
  uint64_t seed = 1;
};
SyntheticPointLight make_synthetic_point_light(const SyntheticPointLightOptions& o);

}  // namespace lf::calib
