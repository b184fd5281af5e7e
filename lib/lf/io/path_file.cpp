#include "lf/io/path_file.h"

#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

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

}  // namespace lf
