#include "lf/io/parse.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "lf/focus/focus.h"

namespace lf {

std::vector<double> parse_number_list(const std::string& s, const std::string& what) {
  std::vector<double> out;
  size_t pos = 0;
  while (pos <= s.size()) {
    const size_t comma = s.find(',', pos);
    const std::string tok =
        s.substr(pos, comma == std::string::npos ? std::string::npos : comma - pos);
    size_t used = 0;
    double v = 0;
    try {
      v = std::stod(tok, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != tok.size() || !std::isfinite(v))
      throw std::invalid_argument(what + ": '" + tok + "' is not a number");
    out.push_back(v);
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return out;
}

cv::Vec3d parse_point(const std::string& s, const std::string& what) {
  const auto v = parse_number_list(s, what);
  if (v.size() != 3) throw std::invalid_argument(what + " '" + s + "' is not 'x,y,z'");
  return {v[0], v[1], v[2]};
}

FocalPlane parse_focal_plane(const std::string& s, const Rig& rig) {
  if (s == "infinity") return FocalPlane::infinity();
  if (s.rfind("depth:", 0) == 0)
    return plane_at_depth(rig, parse_number_list(s.substr(6), "focal depth")[0]);
  if (s.rfind("param:", 0) == 0)
    return plane_from_focal_param(rig, parse_number_list(s.substr(6), "focal parameter")[0]);
  if (s.rfind("plane:", 0) == 0) {
    const auto v = parse_number_list(s.substr(6), "focal plane");
    if (v.size() != 4) throw std::invalid_argument("focal plane needs nx,ny,nz,d");
    const FocalPlane p{{v[0], v[1], v[2]}, v[3]};
    if (p.at_infinity() && p.d == 0) throw std::invalid_argument("focal plane (0,0,0,0)");
    return p;
  }
  throw std::invalid_argument("focal plane '" + s +
                              "': use infinity, depth:Z, param:A or plane:nx,ny,nz,d");
}

double focal_plane_depth(const Rig& rig, const FocalPlane& p) {
  if (p.at_infinity()) return std::numeric_limits<double>::infinity();
  const CameraPlane& cp = rig.plane();
  const double along = p.n.dot(cp.normal);
  if (std::fabs(along) < 1e-12 * cv::norm(p.n)) return std::numeric_limits<double>::infinity();
  return -(p.n.dot(cp.origin) + p.d) / along;  // n . (origin + t normal) + d = 0
}

std::vector<int> parse_index_ranges(const std::string& s, int count, const std::string& what) {
  std::vector<int> out;
  if (s.find_first_not_of(" \t") == std::string::npos) {
    for (int i = 0; i < count; ++i) out.push_back(i);
    return out;
  }
  std::stringstream ss(s);
  std::string tok;
  auto number = [&](const std::string& t) {
    size_t used = 0;
    long v = -1;
    try {
      v = std::stol(t, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || t.find_first_not_of(" \t", used) != std::string::npos || v < 0 || v >= count)
      throw std::invalid_argument(what + ": '" + t + "' is not an index in 0.." +
                                  std::to_string(count - 1));
    return static_cast<int>(v);
  };
  while (std::getline(ss, tok, ',')) {
    const size_t dash = tok.find('-', tok.find_first_not_of(" \t") + 1);
    const int a = number(dash == std::string::npos ? tok : tok.substr(0, dash));
    const int b = dash == std::string::npos ? a : number(tok.substr(dash + 1));
    if (b < a) throw std::invalid_argument(what + ": range '" + tok + "' runs backwards");
    for (int i = a; i <= b; ++i) out.push_back(i);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::string camera_file_name(const std::string& pattern, int camera_id, const std::string& what) {
  std::string out;
  int fields = 0;
  for (size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') {
      out += pattern[i];
      continue;
    }
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      out += '%';
      ++i;
      continue;
    }
    size_t j = i + 1;
    int width = 0;
    if (j < pattern.size() && pattern[j] == '0' && j + 1 < pattern.size() &&
        pattern[j + 1] >= '1' && pattern[j + 1] <= '9') {
      width = pattern[j + 1] - '0';
      j += 2;
    }
    if (j >= pattern.size() || pattern[j] != 'd')
      throw std::invalid_argument(what + " '" + pattern +
                                  "': only one %d or %0Nd (N = 1..9) field is allowed");
    std::string id = std::to_string(camera_id);
    if (static_cast<int>(id.size()) < width) id.insert(0, width - id.size(), '0');
    out += id;
    ++fields;
    i = j;
  }
  if (fields != 1)
    throw std::invalid_argument(what + " '" + pattern +
                                "' needs exactly one %d (the camera id), has " +
                                std::to_string(fields));
  return out;
}

}  // namespace lf
