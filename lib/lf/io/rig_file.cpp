#include "lf/io/rig_file.h"

#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

namespace lf {

// ---------------------------------------------------------------------------
// Rig file

namespace {
using nlohmann::json;
constexpr const char* kFormat = "lightfield-gst-rig";
constexpr int kVersion = 1;
// Bounds checked before anything is built from a file: its size before it is
// read (a JSON document takes about ten times its size in memory: a 350 MB
// rig once took 3.2 GB before it was refused) and its camera count.
constexpr uintmax_t kMaxRigBytes = 16u << 20;  // a 4096-camera rig is about 2.5 MB
constexpr size_t kMaxCameras = 16384;

[[noreturn]] void fail(const std::string& origin, const std::string& what) {
  throw std::runtime_error("rig file " + origin + ": " + what);
}

template <typename T>
T get_field(const json& j, const char* key, const std::string& origin, const std::string& where) {
  if (!j.contains(key)) fail(origin, where + ": missing field '" + key + "'");
  try {
    return j.at(key).get<T>();
  } catch (const json::exception& e) {
    fail(origin, where + ": field '" + key + "' has the wrong type (" + e.what() + ")");
  }
}
// Integers are checked, not converted: a JSON number such as 1e30 or 2^40
// is rejected (converting it to int would be undefined or wrap).
int json_int(const json& v, const std::string& origin, const std::string& what) {
  if (v.is_number_unsigned()) {
    if (v.get<uint64_t>() > static_cast<uint64_t>(std::numeric_limits<int>::max()))
      fail(origin, what + " is out of range");
  } else if (!v.is_number_integer()) {
    fail(origin, what + " must be an integer");
  }
  const int64_t x = v.get<int64_t>();
  if (x < std::numeric_limits<int>::min() || x > std::numeric_limits<int>::max())
    fail(origin, what + " is out of range");
  return static_cast<int>(x);
}

template <>
int get_field<int>(const json& j, const char* key, const std::string& origin,
                   const std::string& where) {
  if (!j.contains(key)) fail(origin, where + ": missing field '" + key + "'");
  return json_int(j.at(key), origin, where + ": field '" + key + "'");
}

Rig parse_rig_json(const json& j, const std::string& origin);

}  // namespace

std::string rig_to_json(const Rig& rig) {
  json j;
  j["format"] = kFormat;
  j["version"] = kVersion;
  j["name"] = rig.name;
  j["unit"] = rig.unit;
  j["conventions"] =
      "extrinsics map world to camera: X_cam = R X + t (R row-major); camera frame x right, "
      "y down, z forward; pixel origin at the centre of the top-left pixel; radial distortion "
      "k1, k2 on normalized coordinates";
  json cams = json::array();
  for (const Camera& c : rig.cameras) {
    json jc;
    jc["id"] = c.id;
    jc["name"] = c.name;
    jc["width"] = c.width;
    jc["height"] = c.height;
    const Intrinsics& k = c.intrinsics;
    jc["intrinsics"] = {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx},
                        {"cy", k.cy}, {"k1", k.k1}, {"k2", k.k2}};
    std::vector<double> R(c.extrinsics.R.val, c.extrinsics.R.val + 9);
    std::vector<double> t(c.extrinsics.t.val, c.extrinsics.t.val + 3);
    jc["R"] = R;
    jc["t"] = t;
    if (!c.image.empty()) jc["image"] = c.image;
    if (c.has_colour_correction())
      jc["colour"] = std::vector<double>(c.colour.val, c.colour.val + 12);
    cams.push_back(jc);
  }
  j["cameras"] = cams;
  if (!rig.grid.empty()) {
    json rows = json::array();
    for (int r = 0; r < rig.grid.rows; ++r) {
      json row = json::array();
      for (int c = 0; c < rig.grid.cols; ++c) {
        const int idx = rig.grid.at(r, c);
        row.push_back(idx >= 0 ? json(rig.cameras[idx].id) : json(nullptr));
      }
      rows.push_back(row);
    }
    j["grid"] = {{"rows", rig.grid.rows}, {"cols", rig.grid.cols}, {"camera_ids", rows}};
  }
  j["triangles"] = rig.triangles;
  if (rig.has_focal_param)
    j["focal_param"] = {{"f_px", rig.focal_param_f_px}, {"a_infinity", rig.focal_param_infinity}};
  return j.dump(1);
}

Rig rig_from_json(const std::string& text, const std::string& origin) {
  if (text.size() > kMaxRigBytes)
    fail(origin, std::to_string(text.size()) + " bytes (at most " + std::to_string(kMaxRigBytes) +
                     "): not parsed");
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {  // parse_error, or out_of_range (1e999)
    fail(origin, std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object()) fail(origin, "top level is not a JSON object");
  // Every nlohmann exception becomes the documented std::runtime_error.
  try {
    return parse_rig_json(j, origin);
  } catch (const json::exception& e) {
    fail(origin, std::string("wrong type or value: ") + e.what());
  }
}

namespace {
Rig parse_rig_json(const json& j, const std::string& origin) {
  const auto format = get_field<std::string>(j, "format", origin, "header");
  if (format != kFormat) fail(origin, "format is '" + format + "', expected '" + kFormat + "'");
  const int version = get_field<int>(j, "version", origin, "header");
  if (version < 1 || version > kVersion)
    fail(origin, "unsupported version " + std::to_string(version) + " (this build reads 1.." +
                     std::to_string(kVersion) + ")");
  Rig rig;
  rig.name = j.value("name", "");
  rig.unit = j.value("unit", "unit");
  if (!j.contains("cameras") || !j["cameras"].is_array()) fail(origin, "missing array 'cameras'");
  if (j["cameras"].size() > kMaxCameras)
    fail(origin, std::to_string(j["cameras"].size()) + " cameras (at most " +
                     std::to_string(kMaxCameras) + ")");
  for (size_t i = 0; i < j["cameras"].size(); ++i) {
    const json& jc = j["cameras"][i];
    const std::string where = "cameras[" + std::to_string(i) + "]";
    Camera c;
    c.id = get_field<int>(jc, "id", origin, where);
    c.name = jc.value("name", "");
    c.width = get_field<int>(jc, "width", origin, where);
    c.height = get_field<int>(jc, "height", origin, where);
    const json ji = get_field<json>(jc, "intrinsics", origin, where);
    c.intrinsics.fx = get_field<double>(ji, "fx", origin, where + ".intrinsics");
    c.intrinsics.fy = get_field<double>(ji, "fy", origin, where + ".intrinsics");
    c.intrinsics.cx = get_field<double>(ji, "cx", origin, where + ".intrinsics");
    c.intrinsics.cy = get_field<double>(ji, "cy", origin, where + ".intrinsics");
    c.intrinsics.k1 = ji.value("k1", 0.0);
    c.intrinsics.k2 = ji.value("k2", 0.0);
    const auto R = get_field<std::vector<double>>(jc, "R", origin, where);
    const auto t = get_field<std::vector<double>>(jc, "t", origin, where);
    if (R.size() != 9) fail(origin, where + ": R must have 9 numbers (row-major)");
    if (t.size() != 3) fail(origin, where + ": t must have 3 numbers");
    for (int k = 0; k < 9; ++k) c.extrinsics.R.val[k] = R[k];
    for (int k = 0; k < 3; ++k) c.extrinsics.t[k] = t[k];
    c.image = jc.value("image", "");
    if (jc.contains("colour")) {
      const auto col = get_field<std::vector<double>>(jc, "colour", origin, where);
      if (col.size() != 12) fail(origin, where + ": colour must have 12 numbers ([A | b], 3x4)");
      for (int k = 0; k < 12; ++k) {
        if (!std::isfinite(col[k])) fail(origin, where + ": colour is not finite");
        c.colour.val[k] = col[k];
      }
    }
    rig.cameras.push_back(c);
  }
  if (j.contains("grid")) {
    const json& g = j["grid"];
    rig.grid.rows = get_field<int>(g, "rows", origin, "grid");
    rig.grid.cols = get_field<int>(g, "cols", origin, "grid");
    if (rig.grid.rows < 0 || rig.grid.cols < 0 || rig.grid.rows > 4096 || rig.grid.cols > 4096)
      fail(origin, "grid: rows/cols out of range 0..4096");
    const json ids = get_field<json>(g, "camera_ids", origin, "grid");
    if (!ids.is_array() || ids.size() != static_cast<size_t>(rig.grid.rows))
      fail(origin, "grid: camera_ids must have 'rows' rows");
    for (const json& row : ids) {
      if (!row.is_array() || row.size() != static_cast<size_t>(rig.grid.cols))
        fail(origin, "grid: every row of camera_ids must have 'cols' entries");
      for (const json& cell : row) {
        if (cell.is_null()) {
          rig.grid.cells.push_back(-1);
          continue;
        }
        const int id = json_int(cell, origin, "grid: camera_ids entry");
        const int idx = rig.index_of(id);
        if (idx < 0) fail(origin, "grid: unknown camera id " + std::to_string(id));
        rig.grid.cells.push_back(idx);
      }
    }
  }
  if (j.contains("triangles")) {
    const json& tris = j["triangles"];
    if (!tris.is_array()) fail(origin, "triangles must be an array of [id, id, id] triples");
    for (const json& t : tris) {
      if (!t.is_array() || t.size() != 3) fail(origin, "triangles must be [id, id, id] triples");
      rig.triangles.push_back({json_int(t[0], origin, "triangle id"),
                               json_int(t[1], origin, "triangle id"),
                               json_int(t[2], origin, "triangle id")});
    }
  }
  if (j.contains("focal_param")) {
    rig.has_focal_param = true;
    rig.focal_param_f_px = get_field<double>(j["focal_param"], "f_px", origin, "focal_param");
    rig.focal_param_infinity =
        get_field<double>(j["focal_param"], "a_infinity", origin, "focal_param");
  }
  try {
    rig.finalize();
  } catch (const std::invalid_argument& e) {
    fail(origin, e.what());
  }
  return rig;
}
}  // namespace

Rig load_rig(const std::string& path) {
  std::error_code ec;
  const uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (!ec && bytes > kMaxRigBytes)
    fail(path,
         std::to_string(bytes) + " bytes (at most " + std::to_string(kMaxRigBytes) + "): not read");
  std::ifstream in(path);
  if (!in) throw std::runtime_error("rig file " + path + ": cannot open");
  std::stringstream ss;
  ss << in.rdbuf();
  Rig rig = rig_from_json(ss.str(), path);
  const auto dir = std::filesystem::absolute(path).parent_path();
  for (Camera& c : rig.cameras)
    if (!c.image.empty() && std::filesystem::path(c.image).is_relative())
      c.image = (dir / c.image).lexically_normal().string();
  return rig;
}

void save_rig(const Rig& rig, const std::string& path) {
  Rig copy = rig;
  const auto dir = std::filesystem::absolute(path).parent_path();
  for (Camera& c : copy.cameras)
    if (!c.image.empty()) {
      std::error_code ec;
      auto rel = std::filesystem::relative(std::filesystem::absolute(c.image), dir, ec);
      if (!ec && !rel.empty()) c.image = rel.string();
    }
  std::ofstream out(path);
  if (!out) throw std::runtime_error("rig file " + path + ": cannot write");
  out << rig_to_json(copy) << "\n";
  if (!out) throw std::runtime_error("rig file " + path + ": write failed");
}

}  // namespace lf
