#include "calib/synthetic_point_light.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <random>

#include "lf/quality/synthetic.h"

namespace lf::calib {

SyntheticPointLight make_synthetic_point_light(const SyntheticPointLightOptions& o) {
  SyntheticPointLight s;
  const double vfov = 2 * std::atan(0.5 * o.height / o.f) * 180 / CV_PI;
  s.truth = synthetic_grid_rig(o.rows, o.cols, o.pitch, o.width, o.height, vfov, o.rot_jitter_deg,
                               o.seed);
  s.truth.unit = "m";
  std::mt19937_64 rng(o.seed * 7919 + 1);
  std::uniform_real_distribution<double> uni(-1, 1), u01(0, 1);
  std::normal_distribution<double> noise(0, o.noise_px);
  for (Camera& c : s.truth.cameras) {
    c.intrinsics.fx = c.intrinsics.fy = o.f * (1 + o.f_spread * uni(rng));
    c.intrinsics.k1 = o.k1;
    c.intrinsics.k2 = o.k2;
  }
  s.zhang = s.truth.cameras[0].intrinsics;
  s.zhang.fx = s.zhang.fy = s.zhang.fx * (1 + o.zhang_f_error);
  // Lights inside the common field of view, spread in depth.
  const double half_w = 0.5 * (o.cols - 1) * o.pitch, half_h = 0.5 * (o.rows - 1) * o.pitch;
  while (static_cast<int>(s.lights.size()) < o.lights) {
    const double z = o.z_min + (o.z_max - o.z_min) * u01(rng);
    const double ex = 0.8 * z * 0.5 * o.width / o.f, ey = 0.8 * z * 0.5 * o.height / o.f;
    s.lights.emplace_back(uni(rng) * (ex - half_w * 0.2), uni(rng) * (ey - half_h * 0.2), z);
  }
  for (int p = 0; p < o.lights; ++p)
    for (size_t c = 0; c < s.truth.cameras.size(); ++c) {
      const auto px = s.truth.cameras[c].project(s.lights[p]);
      if (!px || (*px)[0] < 0 || (*px)[1] < 0 || (*px)[0] > o.width - 1 || (*px)[1] > o.height - 1)
        continue;
      if (u01(rng) < o.dropout) continue;
      PointObservation ob;
      ob.camera = static_cast<int>(c);
      ob.point = p;
      const bool out = u01(rng) < o.outlier_fraction;
      if (out) {  // a stray detection: anywhere at least 5 px away
        do {
          ob.pixel = {u01(rng) * (o.width - 1), u01(rng) * (o.height - 1)};
        } while (cv::norm(ob.pixel - *px) < 5);
      } else {
        ob.pixel = *px + cv::Vec2d(noise(rng), noise(rng));
      }
      s.observations.push_back(ob);
      s.is_outlier.push_back(out);
    }
  return s;
}

}  // namespace lf::calib
