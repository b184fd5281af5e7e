#include "cli.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

namespace cli {

Args::Args(int argc, char** argv, const std::vector<std::string>& with_value,
           const std::vector<std::string>& bare) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (std::find(bare.begin(), bare.end(), a) != bare.end()) {
      values_[a] = "1";
    } else if (std::find(with_value.begin(), with_value.end(), a) != with_value.end()) {
      if (i + 1 >= argc) throw std::invalid_argument("option " + a + " needs a value");
      values_[a] = argv[++i];
    } else {
      throw std::invalid_argument("unknown option '" + a + "' (see --help)");
    }
  }
}

std::string Args::get(const std::string& k, const std::string& def) const {
  auto it = values_.find(k);
  return it == values_.end() ? def : it->second;
}

double Args::number(const std::string& k, double def) const {
  if (!has(k)) return def;
  return parse_numbers(get(k), k).at(0);
}

int Args::integer(const std::string& k, int def) const {
  if (!has(k)) return def;
  const double v = number(k, def);
  if (v != std::floor(v) || std::abs(v) > 1e9)
    throw std::invalid_argument("option " + k + " must be an integer");
  return static_cast<int>(v);
}

std::vector<double> Args::numbers(const std::string& k, size_t n_min, size_t n_max) const {
  auto v = parse_numbers(get(k), k);
  if (v.size() < n_min || v.size() > n_max)
    throw std::invalid_argument("option " + k + " takes " + std::to_string(n_min) +
                                (n_max != n_min ? ".." + std::to_string(n_max) : "") +
                                " comma-separated numbers");
  return v;
}

std::vector<double> parse_numbers(const std::string& s, const std::string& what) {
  std::vector<double> out;
  std::stringstream ss(s);
  std::string tok;
  while (std::getline(ss, tok, ',')) {
    size_t used = 0;
    double v;
    try {
      v = std::stod(tok, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != tok.size() || !std::isfinite(v))
      throw std::invalid_argument(what + ": '" + tok + "' is not a number");
    out.push_back(v);
  }
  if (out.empty()) throw std::invalid_argument(what + ": no value");
  return out;
}

void parse_size(const std::string& s, int& w, int& h) {
  const auto x = s.find('x');
  if (x == std::string::npos) throw std::invalid_argument("size '" + s + "' must be WIDTHxHEIGHT");
  w = static_cast<int>(parse_numbers(s.substr(0, x), "width")[0]);
  h = static_cast<int>(parse_numbers(s.substr(x + 1), "height")[0]);
  if (w < 2 || h < 2 || w > 16384 || h > 16384)
    throw std::invalid_argument("size '" + s + "' outside 2..16384");
}

void progress(const std::string& label, int done, int total) {
  static const bool tty = isatty(2);
  if (!tty && done != total && done % std::max(1, total / 4) != 0) return;
  const int width = 30, filled = total ? width * done / total : width;
  std::fprintf(stderr, "%s%s [%s%s] %d/%d%s", tty ? "\r" : "", label.c_str(),
               std::string(filled, '#').c_str(), std::string(width - filled, ' ').c_str(), done,
               total, (!tty || done == total) ? "\n" : "");
  std::fflush(stderr);
}

FocalSpec parse_focal(const std::string& s, const lf::Rig& rig) {
  FocalSpec f;
  f.text = s;
  if (s == "auto") return f;
  f.kind = FocalSpec::kPlane;
  if (s == "infinity") {
    f.plane = lf::FocalPlane::infinity();
  } else if (s.rfind("depth:", 0) == 0) {
    f.plane = lf::plane_at_depth(rig, parse_numbers(s.substr(6), "focal depth")[0]);
  } else if (s.rfind("param:", 0) == 0) {
    f.plane = lf::plane_from_focal_param(rig, parse_numbers(s.substr(6), "focal parameter")[0]);
  } else if (s.rfind("plane:", 0) == 0) {
    const auto v = parse_numbers(s.substr(6), "focal plane");
    if (v.size() != 4) throw std::invalid_argument("focal plane needs nx,ny,nz,d");
    f.plane = {{v[0], v[1], v[2]}, v[3]};
  } else {
    throw std::invalid_argument("--focal '" + s +
                                "': use auto, infinity, depth:Z, param:A or plane:nx,ny,nz,d");
  }
  return f;
}

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

std::vector<Keyframe> orbit_path(const lf::Rig& rig, double fraction, double dolly, int frames) {
  const lf::CameraPlane& P = rig.plane();
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

std::vector<lf::VirtualView> sample_path(const lf::Rig& rig, const std::vector<Keyframe>& keys,
                                         int frames, int width, int height, bool closed) {
  std::vector<lf::VirtualView> out;
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
      out.push_back(lf::VirtualView::look_at(pos, target, down, vfov, width, height));
    } else {
      out.push_back(lf::view_between_cameras(rig, pos, width, height));
    }
  }
  return out;
}

}  // namespace cli
