#include "lfrig.h"

#include <filesystem>
#include <map>
#include <mutex>

#include "lf/io/datasets.h"
#include "lfguard.h"

namespace fs = std::filesystem;

namespace lfgst {

namespace {
// What identifies the version of a rig on disk: the latest modification time
// and the total size of the file, or of the folder's files.
struct Stamp {
  fs::file_time_type mtime{};
  uintmax_t size = 0;
  bool operator==(const Stamp& o) const { return mtime == o.mtime && size == o.size; }
};
Stamp stamp_of(const fs::path& p) {
  Stamp s;
  std::error_code ec;
  if (fs::is_directory(p, ec)) {
    s.mtime = fs::last_write_time(p, ec);
    for (const auto& e : fs::directory_iterator(p, ec)) {
      if (!e.is_regular_file(ec)) continue;
      s.mtime = std::max(s.mtime, e.last_write_time(ec));
      s.size += e.file_size(ec);
    }
  } else {
    s.mtime = fs::last_write_time(p, ec);
    s.size = fs::file_size(p, ec);
  }
  return s;
}
struct Entry {
  Stamp stamp;
  std::shared_ptr<const lf::Rig> rig;
};
}  // namespace

std::shared_ptr<const lf::Rig> load_rig_cached(const std::string& path) {
  static std::mutex m;
  static std::map<std::string, Entry> cache;
  std::error_code ec;
  fs::path key = fs::weakly_canonical(fs::path(path), ec);
  if (ec) key = fs::absolute(fs::path(path));
  const Stamp st = stamp_of(key);
  std::lock_guard<std::mutex> lock(m);
  auto it = cache.find(key.string());
  if (it != cache.end() && it->second.stamp == st) return it->second.rig;
  auto rig = std::make_shared<const lf::Rig>(lf::load_rig_or_dataset(key.string()));
  cache[key.string()] = {st, rig};
  return rig;
}

std::shared_ptr<const lf::Rig> open_rig(GstElement* el, const std::string& path) {
  if (path.empty()) {
    GST_ELEMENT_ERROR(el, RESOURCE, NOT_FOUND, ("No rig given"),
                      ("set the 'rig' property to a rig file or dataset folder"));
    return nullptr;
  }
  std::shared_ptr<const lf::Rig> rig;
  GError* err = nullptr;
  if (!guard([&] { rig = load_rig_cached(path); }, &err)) {
    GST_ELEMENT_ERROR(el, RESOURCE, OPEN_READ, ("Cannot load the rig '%s'", path.c_str()),
                      ("%s", err->message));
    g_error_free(err);
    return nullptr;
  }
  return rig;
}

int camera_index(GstElement* el, const lf::Rig& rig, const CameraAddress& a) {
  int index = -1;
  GError* err = nullptr;
  if (!guard([&] { index = rig.camera_index(a.camera_id, a.row, a.col); }, &err)) {
    GST_ELEMENT_ERROR(el, RESOURCE, NOT_FOUND, ("No such camera in the rig"), ("%s", err->message));
    g_error_free(err);
    return -1;
  }
  return index;
}

}  // namespace lfgst
