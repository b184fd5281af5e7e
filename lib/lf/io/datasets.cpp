#include "lf/io/datasets.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <stdexcept>

#include "lf/io/image_io.h"
#include "lf/io/rig_file.h"

namespace fs = std::filesystem;

namespace lf {

namespace {

std::vector<std::string> list_files(const std::string& folder) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder, ec))
    if (e.is_regular_file()) out.push_back(e.path().filename().string());
  if (ec) throw std::runtime_error("dataset " + folder + ": cannot list folder: " + ec.message());
  std::sort(out.begin(), out.end());
  return out;
}

cv::Size image_size(const std::string& path) {
  return read_image_size(path);
}

// Builds the grid from (row key, col key) pairs with row/col keys sorted.
template <typename K>
Grid make_grid(const std::vector<std::pair<K, K>>& keys, bool rows_descending,
               bool cols_descending) {
  std::set<K> rs, cs;
  for (const auto& k : keys) rs.insert(k.first), cs.insert(k.second);
  std::vector<K> rv(rs.begin(), rs.end()), cv_(cs.begin(), cs.end());
  if (rows_descending) std::reverse(rv.begin(), rv.end());
  if (cols_descending) std::reverse(cv_.begin(), cv_.end());
  Grid g;
  g.rows = static_cast<int>(rv.size());
  g.cols = static_cast<int>(cv_.size());
  g.cells.assign(static_cast<size_t>(g.rows) * g.cols, -1);
  for (size_t i = 0; i < keys.size(); ++i) {
    const int r = static_cast<int>(std::find(rv.begin(), rv.end(), keys[i].first) - rv.begin());
    const int c = static_cast<int>(std::find(cv_.begin(), cv_.end(), keys[i].second) - cv_.begin());
    g.cells[static_cast<size_t>(r) * g.cols + c] = static_cast<int>(i);
  }
  return g;
}

std::map<std::string, std::string> read_ini(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("dataset file " + path + ": cannot open");
  std::map<std::string, std::string> kv;
  std::string line;
  while (std::getline(in, line)) {
    const auto eq = line.find('=');
    if (eq == std::string::npos || line[0] == '[' || line[0] == '#') continue;
    auto trim = [](std::string s) {
      s.erase(0, s.find_first_not_of(" \t\r"));
      s.erase(s.find_last_not_of(" \t\r") + 1);
      return s;
    };
    kv[trim(line.substr(0, eq))] = trim(line.substr(eq + 1));
  }
  return kv;
}

double ini_number(const std::map<std::string, std::string>& kv, const std::string& key,
                  const std::string& path) {
  auto it = kv.find(key);
  if (it == kv.end()) throw std::runtime_error("dataset file " + path + ": missing key " + key);
  try {
    return std::stod(it->second);
  } catch (const std::exception&) {
    throw std::runtime_error("dataset file " + path + ": key " + key + " is not a number");
  }
}

}  // namespace

std::string detect_dataset(const std::string& folder) {
  if (!fs::is_directory(folder)) return "";
  if (fs::exists(fs::path(folder) / "parameters.cfg")) return "hci";
  for (const auto& f : list_files(folder)) {
    if (std::regex_match(f, std::regex(R"(out_\d+_\d+_-?[0-9.]+_-?[0-9.]+_\.png)")))
      return "stanford";
    if (f.rfind("Original Camera_", 0) == 0) return "blender-shop";
    if (f.size() > 8 && f.substr(f.size() - 8) == "_par.txt") return "middlebury";
  }
  return "";
}

Rig import_dataset(const std::string& folder, const std::string& kind_in) {
  const std::string kind = kind_in.empty() ? detect_dataset(folder) : kind_in;
  if (kind == "stanford") return import_stanford(folder);
  if (kind == "hci") return import_hci(folder);
  if (kind == "blender-shop") return import_blender_shop(folder);
  if (kind == "middlebury") return import_middlebury(folder);
  throw std::runtime_error(
      "dataset " + folder +
      ": not a recognised light-field dataset (expected Stanford out_*.png, "
      "HCI parameters.cfg, Blender 'Original Camera_*' or Middlebury *_par.txt)");
}

Rig import_stanford(const std::string& folder) {
  const std::regex re(R"(out_(\d+)_(\d+)_(-?[0-9.]+)_(-?[0-9.]+)_\.png)");
  std::vector<std::pair<int, int>> keys;
  std::vector<cv::Vec2d> pos;  // (X, Y)
  std::vector<std::string> files;
  for (const auto& f : list_files(folder)) {
    std::smatch m;
    if (!std::regex_match(f, m, re)) continue;
    keys.emplace_back(std::stoi(m[1]), std::stoi(m[2]));
    pos.emplace_back(std::stod(m[4]), std::stod(m[3]));
    files.push_back(f);
  }
  if (files.empty())
    throw std::runtime_error("dataset " + folder + ": no Stanford out_*.png files");
  const cv::Size size = image_size((fs::path(folder) / files[0]).string());
  Rig rig;
  rig.name = "stanford:" + fs::path(folder).filename().string();
  rig.unit = "stanford-parallax-unit";
  rig.grid = make_grid(keys, false, false);
  const double f = size.width, a_inf = 0.5;
  cv::Vec2d mean(0, 0);
  for (const auto& p : pos) mean += p;
  mean *= 1.0 / pos.size();
  for (size_t i = 0; i < files.size(); ++i) {
    Camera c;
    c.id = keys[i].first * 1000 + keys[i].second;
    char name[32];
    std::snprintf(name, sizeof name, "r%02dc%02d", keys[i].first, keys[i].second);
    c.name = name;
    c.width = size.width;
    c.height = size.height;
    c.intrinsics.fx = c.intrinsics.fy = f;
    c.intrinsics.cx = 0.5 * (size.width - 1) + a_inf * (pos[i][0] - mean[0]);
    c.intrinsics.cy = 0.5 * (size.height - 1) + a_inf * (pos[i][1] - mean[1]);
    c.extrinsics = Extrinsics::from_center(cv::Matx33d::eye(), {pos[i][0], pos[i][1], 0.0});
    c.image = (fs::path(folder) / files[i]).string();
    rig.cameras.push_back(c);
  }
  rig.has_focal_param = true;
  rig.focal_param_f_px = f;
  rig.focal_param_infinity = a_inf;
  rig.finalize();
  return rig;
}

Rig import_hci(const std::string& folder) {
  const std::string cfg = (fs::path(folder) / "parameters.cfg").string();
  const auto kv = read_ini(cfg);
  const int W = static_cast<int>(ini_number(kv, "image_resolution_x_px", cfg));
  const int H = static_cast<int>(ini_number(kv, "image_resolution_y_px", cfg));
  const double focal_mm = ini_number(kv, "focal_length_mm", cfg);
  const double sensor_mm = ini_number(kv, "sensor_size_mm", cfg);
  const int nx = static_cast<int>(ini_number(kv, "num_cams_x", cfg));
  const int ny = static_cast<int>(ini_number(kv, "num_cams_y", cfg));
  const double b = ini_number(kv, "baseline_mm", cfg) / 1000.0;
  const double z0 = ini_number(kv, "focus_distance_m", cfg);
  if (W < 2 || H < 2 || nx < 1 || ny < 1 || nx * ny > 10000 || !(focal_mm > 0) ||
      !(sensor_mm > 0) || !(b > 0) || !(z0 > 0))
    throw std::runtime_error("dataset file " + cfg + ": implausible parameters");
  const double f = focal_mm / sensor_mm * std::max(W, H);
  Rig rig;
  rig.name = "hci:" + fs::path(folder).filename().string();
  rig.unit = "m";
  rig.grid.rows = ny;
  rig.grid.cols = nx;
  const double rc = 0.5 * (ny - 1), cc = 0.5 * (nx - 1);
  for (int r = 0; r < ny; ++r)
    for (int col = 0; col < nx; ++col) {
      Camera c;
      c.id = r * nx + col;
      char name[32];
      std::snprintf(name, sizeof name, "input_Cam%03d", c.id);
      c.name = name;
      c.width = W;
      c.height = H;
      const cv::Vec3d C((col - cc) * b, (r - rc) * b, 0.0);
      c.intrinsics.fx = c.intrinsics.fy = f;
      c.intrinsics.cx = 0.5 * (W - 1) + f * C[0] / z0;
      c.intrinsics.cy = 0.5 * (H - 1) + f * C[1] / z0;
      c.extrinsics = Extrinsics::from_center(cv::Matx33d::eye(), C);
      c.image = (fs::path(folder) / (std::string(name) + ".png")).string();
      rig.grid.cells.push_back(static_cast<int>(rig.cameras.size()));
      rig.cameras.push_back(c);
    }
  rig.has_focal_param = true;
  rig.focal_param_f_px = f;
  rig.focal_param_infinity = f / z0;
  rig.finalize();
  return rig;
}

Rig import_blender_shop(const std::string& folder) {
  const std::regex re(
      R"(Original Camera_(\d+)_(\d+)_(-?[0-9.]+)_(-?[0-9.]+)_([0-9.]+)_([0-9.]+)\.jpg)");
  std::vector<std::pair<int, int>> keys;
  std::vector<cv::Vec3d> centers;
  std::vector<std::string> files;
  double focal_mm = 0, sensor_mm = 0;
  for (const auto& f : list_files(folder)) {
    std::smatch m;
    if (!std::regex_match(f, m, re)) continue;
    keys.emplace_back(std::stoi(m[1]), std::stoi(m[2]));
    centers.emplace_back(std::stod(m[4]) / 1000.0, std::stod(m[3]) / 1000.0, 0.0);
    focal_mm = std::stod(m[5]);
    sensor_mm = std::stod(m[6]);
    files.push_back(f);
  }
  if (files.empty())
    throw std::runtime_error("dataset " + folder + ": no 'Original Camera_*.jpg' files");
  if (!(focal_mm > 0) || !(sensor_mm > 0))
    throw std::runtime_error("dataset " + folder + ": bad focal/sensor size in file names");
  const cv::Size size = image_size((fs::path(folder) / files[0]).string());
  const double f = focal_mm / sensor_mm * size.width;
  Rig rig;
  rig.name = "blender-shop";
  rig.unit = "m";
  // j = 0 is the bottom row; i = 0 the rightmost column.
  rig.grid = make_grid(keys, true, true);
  for (size_t i = 0; i < files.size(); ++i) {
    Camera c;
    c.id = keys[i].first * 100 + keys[i].second;
    c.name = "j" + std::to_string(keys[i].first) + "i" + std::to_string(keys[i].second);
    c.width = size.width;
    c.height = size.height;
    c.intrinsics.fx = c.intrinsics.fy = f;
    c.intrinsics.cx = 0.5 * (size.width - 1);
    c.intrinsics.cy = 0.5 * (size.height - 1);
    c.extrinsics = Extrinsics::from_center(cv::Matx33d::eye(), centers[i]);
    c.image = (fs::path(folder) / files[i]).string();
    rig.cameras.push_back(c);
  }
  rig.has_focal_param = true;
  rig.focal_param_f_px = f;
  rig.focal_param_infinity = 0.0;
  rig.finalize();
  return rig;
}

Rig import_middlebury(const std::string& folder) {
  std::string par;
  for (const auto& f : list_files(folder))
    if (f.size() > 8 && f.substr(f.size() - 8) == "_par.txt") par = f;
  if (par.empty()) throw std::runtime_error("dataset " + folder + ": no *_par.txt file");
  const std::string path = (fs::path(folder) / par).string();
  std::ifstream in(path);
  int n = 0;
  if (!(in >> n) || n < 1 || n > 100000)
    throw std::runtime_error("dataset file " + path + ": bad camera count");
  Rig rig;
  rig.name = "middlebury:" + fs::path(folder).filename().string();
  rig.unit = "m";
  for (int i = 0; i < n; ++i) {
    std::string name;
    double k[9], r[9], t[3];
    if (!(in >> name)) throw std::runtime_error("dataset file " + path + ": truncated");
    for (double& v : k) in >> v;
    for (double& v : r) in >> v;
    for (double& v : t) in >> v;
    if (!in) throw std::runtime_error("dataset file " + path + ": bad numbers for camera " + name);
    if (std::abs(k[1]) > 1e-9 || std::abs(k[3]) > 1e-9 || std::abs(k[6]) > 1e-9 ||
        std::abs(k[7]) > 1e-9 || std::abs(k[8] - 1) > 1e-9)
      throw std::runtime_error("dataset file " + path + ": camera " + name +
                               " has skew or a non-canonical K (unsupported)");
    Camera c;
    c.id = i;
    c.name = name;
    c.intrinsics.fx = k[0];
    c.intrinsics.fy = k[4];
    c.intrinsics.cx = k[2];
    c.intrinsics.cy = k[5];
    for (int j = 0; j < 9; ++j) c.extrinsics.R.val[j] = r[j];
    c.extrinsics.t = {t[0], t[1], t[2]};
    c.image = (fs::path(folder) / name).string();
    const cv::Size s = image_size(c.image);
    c.width = s.width;
    c.height = s.height;
    bool duplicate = false;
    for (const Camera& o : rig.cameras)
      if (cv::norm(o.center() - c.center()) < 1e-6) {
        rig.warnings.push_back(name + " has the same camera centre as " + o.name + ": dropped");
        duplicate = true;
      }
    if (!duplicate) rig.cameras.push_back(c);
  }
  rig.finalize();
  return rig;
}

Rig load_rig_or_dataset(const std::string& path) {
  if (fs::is_directory(path)) return import_dataset(path);
  if (!fs::exists(path)) throw std::runtime_error("rig " + path + ": no such file or folder");
  return load_rig(path);
}

std::vector<cv::Mat> load_images(const Rig& rig, const std::function<void(int, int)>& progress) {
  const int n = static_cast<int>(rig.cameras.size());
  std::vector<cv::Mat> images(n);
  std::vector<std::string> errors(n);
  std::atomic<int> done{0};
  cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      const Camera& c = rig.cameras[i];
      if (c.image.empty()) {
        errors[i] = "camera " + std::to_string(c.id) + " has no image file";
        continue;
      }
      cv::Mat m;
      try {
        m = read_image(c.image);
      } catch (const std::exception& e) {
        errors[i] = e.what();
        continue;
      }
      try {
        check_image_fits(c.image, m.size(), c.width, c.height);
      } catch (const std::exception& e) {
        errors[i] = e.what();
        continue;
      }
      cv::Mat bgra;
      cv::cvtColor(m, bgra, cv::COLOR_BGR2BGRA);
      if (bgra.cols != c.width || bgra.rows != c.height)
        cv::resize(bgra, bgra, cv::Size(c.width, c.height), 0, 0, cv::INTER_AREA);
      images[i] = bgra;
      const int k = ++done;
      if (progress) progress(k, n);
    }
  });
  for (const auto& e : errors)
    if (!e.empty()) throw std::runtime_error(e);
  return images;
}

cv::Mat read_pfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("PFM " + path + ": cannot open");
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  if ((magic != "Pf" && magic != "PF") || w < 1 || h < 1 || w > 65535 || h > 65535 || scale == 0)
    throw std::runtime_error("PFM " + path + ": bad header");
  const int ch = magic == "PF" ? 3 : 1;
  cv::Mat m(h, w, ch == 3 ? CV_32FC3 : CV_32FC1);
  const bool little = scale < 0;
  for (int y = h - 1; y >= 0; --y) {
    in.read(reinterpret_cast<char*>(m.ptr(y)), static_cast<std::streamsize>(w) * ch * 4);
    if (!in) throw std::runtime_error("PFM " + path + ": truncated");
    if (!little) {
      auto* p = m.ptr<uint8_t>(y);
      for (int i = 0; i < w * ch; ++i) std::reverse(p + 4 * i, p + 4 * i + 4);
    }
  }
  return m;
}

}  // namespace lf
