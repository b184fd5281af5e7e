#include "lf/geometry/rig_ops.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace lf {

Rig grid_block(const Rig& rig, int r0, int c0, int rows, int cols) {
  if (rig.grid.empty())
    throw std::invalid_argument("grid_block: rig '" + rig.name + "' has no grid");
  if (r0 < 0 || c0 < 0 || rows < 1 || cols < 1 || r0 + rows > rig.grid.rows ||
      c0 + cols > rig.grid.cols)
    throw std::invalid_argument(
        "grid_block: block " + std::to_string(rows) + "x" + std::to_string(cols) + " at (" +
        std::to_string(r0) + ", " + std::to_string(c0) + ") exceeds the " +
        std::to_string(rig.grid.rows) + "x" + std::to_string(rig.grid.cols) + " grid");
  std::vector<int> keep;
  for (int r = r0; r < r0 + rows; ++r)
    for (int c = c0; c < c0 + cols; ++c)
      if (rig.grid.at(r, c) >= 0) keep.push_back(rig.grid.at(r, c));
  return rig.subset(keep);
}

Rig grid_spread(const Rig& rig, int k) {
  if (rig.grid.empty())
    throw std::invalid_argument("grid_spread: rig '" + rig.name + "' has no grid");
  if (k < 2 || k > rig.grid.rows || k > rig.grid.cols)
    throw std::invalid_argument("grid_spread: " + std::to_string(k) + "x" + std::to_string(k) +
                                " does not fit the " + std::to_string(rig.grid.rows) + "x" +
                                std::to_string(rig.grid.cols) + " grid (k >= 2)");
  auto spread = [k](int n) {
    std::vector<int> v;
    for (int i = 0; i < k; ++i) v.push_back(static_cast<int>(std::lround(i * (n - 1.0) / (k - 1))));
    return v;
  };
  std::vector<int> keep;
  for (int r : spread(rig.grid.rows))
    for (int c : spread(rig.grid.cols))
      if (rig.grid.at(r, c) >= 0) keep.push_back(rig.grid.at(r, c));
  return rig.subset(keep);
}

Rig scale_rig(const Rig& rig, double scale) {
  if (!(scale > 0) || scale > 16) throw std::invalid_argument("scale_rig: scale out of range");
  Rig out = rig;
  for (Camera& c : out.cameras) {
    const int w = std::max(2, static_cast<int>(std::lround(c.width * scale)));
    const int h = std::max(2, static_cast<int>(std::lround(c.height * scale)));
    const double sx = static_cast<double>(w) / c.width, sy = static_cast<double>(h) / c.height;
    Intrinsics& k = c.intrinsics;
    k.fx *= sx, k.cx = (k.cx + 0.5) * sx - 0.5;
    k.fy *= sy, k.cy = (k.cy + 0.5) * sy - 0.5;
    c.width = w;
    c.height = h;
  }
  if (out.has_focal_param) out.focal_param_f_px *= scale, out.focal_param_infinity *= scale;
  out.triangles.clear();
  out.finalize();
  return out;
}

std::vector<int> host_blocks(const Rig& rig, int hosts) {
  const int n = static_cast<int>(rig.cameras.size());
  if (hosts < 1 || hosts > n)
    throw std::invalid_argument("host_blocks: " + std::to_string(hosts) + " hosts for " +
                                std::to_string(n) + " cameras");
  std::vector<int> host(n, -1);
  if (rig.grid.empty()) {
    for (int i = 0; i < n; ++i) host[i] = static_cast<int>(static_cast<int64_t>(i) * hosts / n);
    return host;
  }
  const int R = rig.grid.rows, C = rig.grid.cols;
  int br = 1;
  double best = -1;
  for (int r = 1; r <= hosts; ++r) {
    if (hosts % r != 0 || r > R || hosts / r > C) continue;
    const double h = static_cast<double>(R) / r, w = static_cast<double>(C) / (hosts / r);
    const double squareness = std::min(h, w) / std::max(h, w);
    if (squareness > best) best = squareness, br = r;
  }
  if (best < 0)
    throw std::invalid_argument("host_blocks: a " + std::to_string(R) + "x" + std::to_string(C) +
                                " grid cannot be cut into " + std::to_string(hosts) + " blocks");
  const int bc = hosts / br;
  for (int r = 0; r < R; ++r)
    for (int c = 0; c < C; ++c) {
      const int i = rig.grid.at(r, c);
      if (i >= 0) host[i] = (r * br / R) * bc + c * bc / C;
    }
  // Cameras outside the grid (none in a gridded rig): the last host.
  for (int& h : host)
    if (h < 0) h = hosts - 1;
  return host;
}

}  // namespace lf
