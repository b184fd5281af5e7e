#include "lf/path.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "lf/renderer.h"

namespace lf {

std::vector<Keyframe> load_path(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error("camera path " + file + ": cannot open");
  nlohmann::json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    throw std::runtime_error("camera path " + file + ": " + e.what());
  }
  std::vector<Keyframe> keys;
  if (!j.contains("keyframes") || !j["keyframes"].is_array() || j["keyframes"].size() < 2)
    throw std::runtime_error("camera path " + file + ": needs a 'keyframes' array of >= 2");
  try {
    for (const auto& k : j["keyframes"]) {
      Keyframe kf;
      const auto p = k.at("position").get<std::vector<double>>();
      if (p.size() != 3) throw std::runtime_error("position needs 3 numbers");
      kf.position = {p[0], p[1], p[2]};
      if (k.contains("look_at")) {
        const auto l = k.at("look_at").get<std::vector<double>>();
        if (l.size() != 3) throw std::runtime_error("look_at needs 3 numbers");
        kf.has_look_at = true;
        kf.look_at = {l[0], l[1], l[2]};
      }
      kf.vfov = k.value("vfov", 0.0);
      keys.push_back(kf);
    }
  } catch (const std::exception& e) {
    throw std::runtime_error("camera path " + file + ": " + e.what());
  }
  return keys;
}

std::vector<Keyframe> orbit_path(const Rig& rig, double fraction, double dolly, int frames) {
  const CameraPlane& P = rig.plane();
  double ext_s = 0, ext_t = 0;
  for (const auto& p : rig.plane_positions())
    ext_s = std::max(ext_s, std::abs(p[0])), ext_t = std::max(ext_t, std::abs(p[1]));
  std::vector<Keyframe> keys;
  for (int k = 0; k < frames; ++k) {
    const double a = 2 * CV_PI * k / frames;
    Keyframe kf;
    kf.position = P.origin + P.u * (fraction * ext_s * std::cos(a)) +
                  P.v * (fraction * ext_t * std::sin(a)) + P.normal * (dolly * std::sin(2 * a));
    keys.push_back(kf);
  }
  return keys;
}

namespace {
cv::Vec3d catmull(const cv::Vec3d& p0, const cv::Vec3d& p1, const cv::Vec3d& p2,
                  const cv::Vec3d& p3, double t) {
  const double t2 = t * t, t3 = t2 * t;
  return 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2 +
                (-p0 + 3 * p1 - 3 * p2 + p3) * t3);
}
}  // namespace

std::vector<VirtualView> sample_path(const Rig& rig, const std::vector<Keyframe>& keys, int frames,
                                     int width, int height, bool closed) {
  std::vector<VirtualView> out;
  const int n = static_cast<int>(keys.size());
  for (int f = 0; f < frames; ++f) {
    const double u = closed ? static_cast<double>(f) * n / frames
                            : (frames > 1 ? static_cast<double>(f) * (n - 1) / (frames - 1) : 0);
    int i = std::min(static_cast<int>(std::floor(u)), closed ? n - 1 : n - 2);
    const double t = u - i;
    auto at = [&](int k) -> const Keyframe& {
      if (closed) return keys[((k % n) + n) % n];
      return keys[std::clamp(k, 0, n - 1)];
    };
    const cv::Vec3d pos =
        catmull(at(i - 1).position, at(i).position, at(i + 1).position, at(i + 2).position, t);
    const Keyframe& a = at(i);
    const Keyframe& b = at(i + 1);
    if (a.has_look_at && b.has_look_at) {
      const cv::Vec3d target = a.look_at * (1 - t) + b.look_at * t;
      const double vfov = (a.vfov > 0 && b.vfov > 0) ? a.vfov * (1 - t) + b.vfov * t : 50.0;
      cv::Vec3d down(rig.cameras[0].extrinsics.R(1, 0), rig.cameras[0].extrinsics.R(1, 1),
                     rig.cameras[0].extrinsics.R(1, 2));
      out.push_back(VirtualView::look_at(pos, target, down, vfov, width, height));
    } else {
      out.push_back(view_between_cameras(rig, pos, width, height));
    }
  }
  return out;
}

}  // namespace lf
