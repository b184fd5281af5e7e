#include "lf/geometry/rig.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>
#include <stdexcept>

namespace lf {

namespace {

std::string cam_label(const Camera& c) {
  return "camera " + std::to_string(c.id) + (c.name.empty() ? "" : " (" + c.name + ")");
}

void check_camera(const Camera& c) {
  auto bad = [&](const std::string& what) {
    throw std::invalid_argument("rig: " + cam_label(c) + ": " + what);
  };
  if (c.width < 2 || c.height < 2 || c.width > 65535 || c.height > 65535)
    bad("image size " + std::to_string(c.width) + "x" + std::to_string(c.height) +
        " is outside 2..65535");
  const Intrinsics& k = c.intrinsics;
  for (double v : {k.fx, k.fy, k.cx, k.cy, k.k1, k.k2})
    if (!std::isfinite(v)) bad("intrinsics are not finite");
  if (!(k.fx > 0) || !(k.fy > 0)) bad("focal lengths fx, fy must be > 0");
  // Plausible, not only finite: a focal length of 10^4 image sides is a
  // field of view of 0.006 degrees; further out the geometry overflows or
  // loses every digit (fx 1e308 was accepted once).
  const double side = std::max(c.width, c.height);
  if (k.fx > 1e4 * side || k.fy > 1e4 * side)
    bad("focal length fx " + std::to_string(k.fx) + " or fy " + std::to_string(k.fy) +
        " px is over 10^4 times the image side (a field of view under 0.006 degrees)");
  if (std::fabs(k.cx) > 10 * side || std::fabs(k.cy) > 10 * side)
    bad("principal point cx, cy is over 10 image sides from the image");
  if (std::fabs(k.k1) > 100 || std::fabs(k.k2) > 100) bad("distortion |k1| or |k2| is over 100");
  const cv::Matx33d& R = c.extrinsics.R;
  for (int i = 0; i < 9; ++i)
    if (!std::isfinite(R.val[i])) bad("rotation R is not finite");
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(c.extrinsics.t[i]) || std::fabs(c.extrinsics.t[i]) > 1e9)
      bad("translation t is not finite or over 10^9 rig units");
  const double orth = cv::norm(R * R.t() - cv::Matx33d::eye(), cv::NORM_INF);
  if (orth > 1e-6 || cv::determinant(R) < 0) bad("R is not a rotation (R R^T != I or det < 0)");
}

}  // namespace

int Rig::index_of(int id) const {
  for (size_t i = 0; i < cameras.size(); ++i)
    if (cameras[i].id == id) return static_cast<int>(i);
  return -1;
}

int Rig::camera_index(int camera_id, int row, int col) const {
  if (camera_id >= 0) {
    const int i = index_of(camera_id);
    if (i < 0)
      throw std::invalid_argument("camera-id " + std::to_string(camera_id) + " is not in the rig");
    return i;
  }
  if (row < 0 || col < 0) throw std::invalid_argument("set camera-id, or row and col");
  if (grid.empty() || row >= grid.rows || col >= grid.cols || grid.at(row, col) < 0)
    throw std::invalid_argument("no camera at grid row " + std::to_string(row) + ", column " +
                                std::to_string(col));
  return grid.at(row, col);
}

void Rig::finalize() {
  if (cameras.empty()) throw std::invalid_argument("rig '" + name + "': no cameras");
  std::set<int> ids;
  for (const Camera& c : cameras) {
    check_camera(c);
    if (!ids.insert(c.id).second)
      throw std::invalid_argument("rig: duplicate camera id " + std::to_string(c.id));
  }
  if (!grid.empty()) {
    if (grid.cells.size() != static_cast<size_t>(grid.rows) * grid.cols)
      throw std::invalid_argument("rig: grid has " + std::to_string(grid.cells.size()) +
                                  " cells, expected rows*cols");
    for (int idx : grid.cells)
      if (idx < -1 || idx >= static_cast<int>(cameras.size()))
        throw std::invalid_argument("rig: grid cell refers to unknown camera index " +
                                    std::to_string(idx));
  }
  compute_plane();
  triangulate();
  build_simplices();
}

void Rig::compute_plane() {
  const size_t n = cameras.size();
  cv::Vec3d mean(0, 0, 0), fwd(0, 0, 0), right(0, 0, 0);
  for (const Camera& c : cameras) {
    mean += c.center();
    fwd += c.forward();
    right += cv::Vec3d(c.extrinsics.R(0, 0), c.extrinsics.R(0, 1), c.extrinsics.R(0, 2));
  }
  mean *= 1.0 / n;
  double extent = 0;
  for (const Camera& c : cameras) extent = std::max(extent, cv::norm(c.center() - mean));
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      if (cv::norm(cameras[i].center() - cameras[j].center()) <= 1e-9 * extent)
        throw std::invalid_argument("rig: " + cam_label(cameras[i]) + " and " +
                                    cam_label(cameras[j]) + " share the same centre");
  auto unit = [](cv::Vec3d v) { return v / cv::norm(v); };
  auto orthogonal_to = [](const cv::Vec3d& v, const cv::Vec3d& axis) {
    return v - axis * v.dot(axis);
  };
  if (cv::norm(fwd) < 1e-9) fwd = cameras[0].forward();
  fwd = unit(fwd);
  if (cv::norm(right) < 1e-9)
    right = cv::Vec3d(cameras[0].extrinsics.R(0, 0), cameras[0].extrinsics.R(0, 1),
                      cameras[0].extrinsics.R(0, 2));
  plane_.origin = mean;
  if (n == 1) {
    dimension_ = 0;
    plane_.normal = fwd;
    plane_.u = unit(orthogonal_to(right, fwd));
  } else {
    cv::Matx33d cov = cv::Matx33d::zeros();
    for (const Camera& c : cameras) {
      const cv::Vec3d d = c.center() - mean;
      cov += d * d.t();
    }
    cv::Mat evals, evecs;
    cv::eigen(cv::Mat(cov), evals, evecs);  // descending
    auto row = [&](int r) {
      return cv::Vec3d(evecs.at<double>(r, 0), evecs.at<double>(r, 1), evecs.at<double>(r, 2));
    };
    const double l1 = evals.at<double>(0), l2 = evals.at<double>(1);
    if (l2 <= 1e-12 * l1) {
      dimension_ = 1;
      cv::Vec3d line = row(0);
      cv::Vec3d nrm = orthogonal_to(fwd, line);
      if (cv::norm(nrm) < 1e-9) nrm = orthogonal_to(cv::Vec3d(0, 0, 1), line);
      if (cv::norm(nrm) < 1e-9) nrm = orthogonal_to(cv::Vec3d(0, 1, 0), line);
      plane_.normal = unit(nrm);
      plane_.u = line.dot(right) < 0 ? -line : line;
    } else {
      dimension_ = 2;
      cv::Vec3d nrm = row(2);
      if (nrm.dot(fwd) < 0) nrm = -nrm;
      plane_.normal = nrm;
      cv::Vec3d u = orthogonal_to(right, nrm);
      if (cv::norm(u) < 1e-9) u = row(0);
      plane_.u = unit(u);
    }
  }
  plane_.v = plane_.normal.cross(plane_.u);
  plane_pos_.clear();
  for (const Camera& c : cameras) plane_pos_.push_back(plane_.to_plane(c.center()));
  std::vector<double> nn;
  for (size_t i = 0; i < n; ++i) {
    double best = INFINITY;
    for (size_t j = 0; j < n; ++j)
      if (j != i) best = std::min(best, cv::norm(plane_pos_[i] - plane_pos_[j]));
    nn.push_back(best);
  }
  std::nth_element(nn.begin(), nn.begin() + nn.size() / 2, nn.end());
  spacing_ = n > 1 ? nn[nn.size() / 2] : 1.0;
  if (!(spacing_ > 0)) spacing_ = 1.0;
}

namespace {
double area2(const cv::Vec2d& a, const cv::Vec2d& b, const cv::Vec2d& c) {
  return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
}

// Delaunay triangulation (cv::Subdiv2D) of 2D points; returns index triples.
std::vector<std::array<int, 3>> delaunay(const std::vector<cv::Point2d>& pts) {
  double minx = INFINITY, miny = INFINITY, maxx = -INFINITY, maxy = -INFINITY;
  for (const auto& p : pts) {
    minx = std::min(minx, p.x), maxx = std::max(maxx, p.x);
    miny = std::min(miny, p.y), maxy = std::max(maxy, p.y);
  }
  const double scale = 1000.0 / std::max({maxx - minx, maxy - miny, 1e-300});
  cv::Subdiv2D subdiv(cv::Rect(-10, -10, 1021, 1021));
  std::map<std::pair<float, float>, int> index;
  for (size_t i = 0; i < pts.size(); ++i) {
    cv::Point2f q(static_cast<float>((pts[i].x - minx) * scale),
                  static_cast<float>((pts[i].y - miny) * scale));
    index[{q.x, q.y}] = static_cast<int>(i);
    subdiv.insert(q);
  }
  std::vector<cv::Vec6f> tris;
  subdiv.getTriangleList(tris);
  std::vector<std::array<int, 3>> out;
  for (const auto& t : tris) {
    std::array<int, 3> tri;
    bool ok = true;
    for (int k = 0; k < 3 && ok; ++k) {
      auto it = index.find({t[2 * k], t[2 * k + 1]});
      if (it == index.end())
        ok = false;
      else
        tri[k] = it->second;
    }
    if (ok) out.push_back(tri);
  }
  return out;
}
}  // namespace

void Rig::triangulate() {
  if (dimension_ < 2) {
    triangles.clear();
    return;
  }
  std::vector<std::array<int, 3>> tri_idx;  // camera indices
  if (!triangles.empty()) {
    for (const auto& t : triangles) {
      std::array<int, 3> ti;
      for (int k = 0; k < 3; ++k) {
        ti[k] = index_of(t[k]);
        if (ti[k] < 0)
          throw std::invalid_argument("rig: triangle names unknown camera id " +
                                      std::to_string(t[k]));
      }
      tri_idx.push_back(ti);
    }
  } else {
    std::vector<cv::Point2d> pts(cameras.size());
    std::vector<cv::Vec2d> lattice(cameras.size());
    bool use_grid = !grid.empty();
    if (use_grid) {
      std::vector<int> seen(cameras.size(), 0);
      for (int r = 0; r < grid.rows; ++r)
        for (int c = 0; c < grid.cols; ++c) {
          const int idx = grid.at(r, c);
          if (idx < 0) continue;
          // A slight shear makes every cell split along the same diagonal.
          lattice[idx] = cv::Vec2d(c + 1e-3 * r, r);
          seen[idx]++;
        }
      for (size_t i = 0; i < cameras.size(); ++i)
        if (seen[i] != 1) use_grid = false;  // camera outside (or twice in) the grid
    }
    for (size_t i = 0; i < cameras.size(); ++i) {
      const cv::Vec2d p = use_grid ? lattice[i] : plane_pos_[i];
      pts[i] = {p[0], p[1]};
    }
    tri_idx = delaunay(pts);
    // Drop slivers from collinear lattice boundaries.
    tri_idx.erase(std::remove_if(tri_idx.begin(), tri_idx.end(),
                                 [&](const std::array<int, 3>& t) {
                                   return std::abs(area2(cv::Vec2d(pts[t[0]].x, pts[t[0]].y),
                                                         cv::Vec2d(pts[t[1]].x, pts[t[1]].y),
                                                         cv::Vec2d(pts[t[2]].x, pts[t[2]].y))) <
                                          1e-6;
                                 }),
                  tri_idx.end());
  }
  // Orient every triangle counter-clockwise on the camera plane and check
  // that the triangulation does not fold over.
  const double min_area = 1e-9 * spacing_ * spacing_;
  int positive = 0, negative = 0;
  std::vector<double> signs;
  for (auto& t : tri_idx) {
    const double a = area2(plane_pos_[t[0]], plane_pos_[t[1]], plane_pos_[t[2]]);
    if (std::abs(a) <= min_area)
      throw std::invalid_argument("rig: triangle of cameras " + cam_label(cameras[t[0]]) + ", " +
                                  cam_label(cameras[t[1]]) + ", " + cam_label(cameras[t[2]]) +
                                  " is degenerate on the camera plane");
    (a > 0 ? positive : negative)++;
  }
  if (positive > 0 && negative > 0 && triangles.empty()) {
    // Lattice orientation and measured orientation disagree for some triangles.
    throw std::invalid_argument("rig: the grid triangulation folds over on the camera plane (" +
                                std::to_string(std::min(positive, negative)) +
                                " triangles flipped): camera positions contradict the grid");
  }
  triangles.clear();
  for (auto& t : tri_idx) {
    if (area2(plane_pos_[t[0]], plane_pos_[t[1]], plane_pos_[t[2]]) < 0) std::swap(t[1], t[2]);
    triangles.push_back({cameras[t[0]].id, cameras[t[1]].id, cameras[t[2]].id});
  }
}

void Rig::build_simplices() {
  simplices_.clear();
  facets_.clear();
  if (dimension_ == 0) {
    Simplex s;
    s.size = 1;
    s.cams[0] = 0;
    simplices_.push_back(s);
    return;
  }
  if (dimension_ == 1) {
    std::vector<int> order(cameras.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return plane_pos_[a][0] < plane_pos_[b][0]; });
    // Facet k: the point s = s_k, form (1, 0, -s_k) (positive beyond it).
    for (int idx : order)
      facets_.push_back({1.0, 0.0, -plane_pos_[idx][0], plane_pos_[idx][0], 0.0});
    for (size_t k = 0; k + 1 < order.size(); ++k) {
      Simplex s;
      s.size = 2;
      s.cams = {order[k], order[k + 1], -1};
      // weight(a) ~ s_b - s = -(facet b); weight(b) ~ s - s_a = +(facet a).
      s.facet = {static_cast<int>(k + 1), static_cast<int>(k), -1};
      s.sign = {-1, +1, 0};
      simplices_.push_back(s);
    }
    return;
  }
  std::map<std::pair<int, int>, int> edge_index;
  auto facet_of = [&](int i, int j, int& sign) {
    // Canonical edge (lo -> hi); form = cross(P_hi - P_lo, X - P_lo).
    const int lo = std::min(i, j), hi = std::max(i, j);
    sign = (i == lo) ? 1 : -1;
    auto it = edge_index.find({lo, hi});
    if (it != edge_index.end()) return it->second;
    const cv::Vec2d& p = plane_pos_[lo];
    const cv::Vec2d d = plane_pos_[hi] - p;
    facets_.push_back({-d[1], d[0], d[1] * p[0] - d[0] * p[1], p[0], p[1]});
    const int id = static_cast<int>(facets_.size()) - 1;
    edge_index[{lo, hi}] = id;
    return id;
  };
  for (const auto& t : triangles) {
    Simplex s;
    s.size = 3;
    for (int k = 0; k < 3; ++k) s.cams[k] = index_of(t[k]);
    for (int k = 0; k < 3; ++k) {
      // Vertex k's weight is proportional to the edge function of the
      // opposite edge (k+1 -> k+2), positive on the left (where k lies).
      s.facet[k] = facet_of(s.cams[(k + 1) % 3], s.cams[(k + 2) % 3], s.sign[k]);
    }
    simplices_.push_back(s);
  }
}

Rig Rig::without(const std::vector<int>& drop) const {
  std::vector<int> keep;
  for (size_t i = 0; i < cameras.size(); ++i)
    if (std::find(drop.begin(), drop.end(), static_cast<int>(i)) == drop.end())
      keep.push_back(static_cast<int>(i));
  Rig r = subset(keep);
  if (!grid.empty()) {
    // Keep the full grid extent so that holes stay holes (and get filled).
    std::vector<int> remap(cameras.size(), -1);
    for (size_t k = 0; k < keep.size(); ++k) remap[keep[k]] = static_cast<int>(k);
    r.grid = grid;
    for (int& c : r.grid.cells) c = c >= 0 ? remap[c] : -1;
    r.triangles.clear();
    r.finalize();
  }
  return r;
}

Rig Rig::subset(const std::vector<int>& keep) const {
  Rig r;
  r.name = name;
  r.unit = unit;
  r.has_focal_param = has_focal_param;
  r.focal_param_f_px = focal_param_f_px;
  r.focal_param_infinity = focal_param_infinity;
  std::vector<int> remap(cameras.size(), -1);
  for (int i : keep) {
    if (i < 0 || i >= static_cast<int>(cameras.size()))
      throw std::invalid_argument("rig subset: camera index " + std::to_string(i) +
                                  " out of range");
    remap[i] = static_cast<int>(r.cameras.size());
    r.cameras.push_back(cameras[i]);
  }
  if (!grid.empty()) {
    int r0 = grid.rows, r1 = -1, c0 = grid.cols, c1 = -1;
    for (int rr = 0; rr < grid.rows; ++rr)
      for (int cc = 0; cc < grid.cols; ++cc)
        if (grid.at(rr, cc) >= 0 && remap[grid.at(rr, cc)] >= 0) {
          r0 = std::min(r0, rr), r1 = std::max(r1, rr);
          c0 = std::min(c0, cc), c1 = std::max(c1, cc);
        }
    if (r1 >= 0) {
      r.grid.rows = r1 - r0 + 1;
      r.grid.cols = c1 - c0 + 1;
      for (int rr = r0; rr <= r1; ++rr)
        for (int cc = c0; cc <= c1; ++cc) {
          const int idx = grid.at(rr, cc);
          r.grid.cells.push_back(idx >= 0 ? remap[idx] : -1);
        }
    }
  }
  r.finalize();
  return r;
}

}  // namespace lf
