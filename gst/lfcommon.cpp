#include "lfcommon.h"

#include <map>
#include <mutex>
#include <sstream>

#include "lf/datasets.h"

namespace lfgst {

std::shared_ptr<const lf::Rig> load_rig_cached(const std::string& path) {
  static std::mutex m;
  static std::map<std::string, std::shared_ptr<const lf::Rig>> cache;
  std::lock_guard<std::mutex> lock(m);
  auto it = cache.find(path);
  if (it != cache.end()) return it->second;
  auto rig = std::make_shared<const lf::Rig>(lf::load_rig_or_dataset(path));
  cache[path] = rig;
  return rig;
}

bool parse_vec3(const gchar* s, cv::Vec3d& out) {
  if (!s) return false;
  std::stringstream ss(s);
  std::string tok;
  int n = 0;
  while (std::getline(ss, tok, ',')) {
    if (n >= 3) return false;
    try {
      size_t used = 0;
      out[n] = std::stod(tok, &used);
      if (used != tok.size() || !std::isfinite(out[n])) return false;
    } catch (const std::exception&) {
      return false;
    }
    ++n;
  }
  return n == 3;
}

}  // namespace lfgst
