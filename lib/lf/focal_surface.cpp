#include "lf/focal_surface.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace lf {

FocalSurfaceEstimator::FocalSurfaceEstimator(const Rig& rig, const std::vector<cv::Mat>& images,
                                             SurfaceOptions opt)
    : rig_(&rig), opt_(opt) {
  auto bad = [](const std::string& what) {
    throw std::invalid_argument("focal surface estimator: " + what);
  };
  if (opt.tile < FocalSurface::kMinTile || opt.tile > FocalSurface::kMaxTile)
    bad("tile " + std::to_string(opt.tile) + " is outside " +
        std::to_string(FocalSurface::kMinTile) + ".." + std::to_string(FocalSurface::kMaxTile));
  if (opt.planes < 3 || opt.planes >= FocalSurface::kMaxPlanes)
    bad("planes must be 3.." + std::to_string(FocalSurface::kMaxPlanes - 1));
  if (opt.analysis_width < 16) bad("analysis width below 16 pixels");
  if (opt.stride < 1 || opt.stride > opt.planes) bad("stride must be 1..planes");
  if (!(opt.max_parallax_px > 0) || !(opt.truncate > 0)) bad("parallax and truncation must be > 0");
  std::vector<double> f;
  for (const Camera& c : rig.cameras) f.push_back(c.intrinsics.fx);
  if (f.empty()) bad("empty rig");
  std::nth_element(f.begin(), f.begin() + f.size() / 2, f.end());
  q_max_ = opt.max_parallax_px / (f[f.size() / 2] * rig.typical_spacing());
  analysis_ = analysis_images(rig, images, opt.analysis_width);
}

SurfaceEstimate FocalSurfaceEstimator::estimate(const ViewRequest& req, SurfaceCosts* carry) const {
  validate(req);
  const int W = req.view.width, H = req.view.height, T = opt_.tile, N = opt_.planes;
  const int aw = std::min(opt_.analysis_width, W);
  const ViewRequest sreq = scaled_request(req, aw);
  const int ah = sreq.view.height;
  const int cols = (W + T - 1) / T, rows = (H + T - 1) / T, tiles = cols * rows;

  SurfaceCosts local;
  SurfaceCosts& c = carry ? *carry : local;
  if (c.cols != cols || c.rows != rows || c.width != W || c.height != H ||
      c.have.size() != static_cast<size_t>(N)) {
    c = SurfaceCosts{};
    c.cols = cols, c.rows = rows, c.width = W, c.height = H;
    c.sum.assign(static_cast<size_t>(N) * tiles, 0.0);
    c.count.assign(c.sum.size(), 0.0);
    c.have.assign(N, false);
  }
  // Tile of each analysis column and row.
  std::vector<int> tx(aw), ty(ah);
  for (int x = 0; x < aw; ++x) tx[x] = std::min(cols - 1, static_cast<int>((x + 0.5) * W / aw) / T);
  for (int y = 0; y < ah; ++y) ty[y] = std::min(rows - 1, static_cast<int>((y + 0.5) * H / ah) / T);

  SurfaceEstimate out;
  cv::Mat cost;
  for (int k = 0; k < N; ++k) {
    if (c.have[k] && k % opt_.stride != c.phase) continue;
    photo_consistency(analysis_.rig, analysis_.gray, sreq, candidate_q(k), opt_.truncate, cost);
    double* sum = &c.sum[static_cast<size_t>(k) * tiles];
    double* cnt = &c.count[static_cast<size_t>(k) * tiles];
    std::fill(sum, sum + tiles, 0.0);
    std::fill(cnt, cnt + tiles, 0.0);
    for (int y = 0; y < ah; ++y) {
      const float* row = cost.ptr<float>(y);
      for (int x = 0; x < aw; ++x) {
        if (row[x] < 0) continue;
        const int t = ty[y] * cols + tx[x];
        sum[t] += row[x];
        cnt[t] += 1.0;
      }
    }
    c.have[k] = true;
    ++out.planes_evaluated;
  }
  c.phase = (c.phase + 1) % opt_.stride;

  // The single plane: minimum of the whole view's mean cost, parabola-refined.
  std::vector<double> global(N);
  for (int k = 0; k < N; ++k) {
    double s = 0, n = 0;
    for (int t = 0; t < tiles; ++t) s += c.sum[k * tiles + t], n += c.count[k * tiles + t];
    global[k] = n > 0 ? s / n : opt_.truncate * opt_.truncate;
  }
  const int kb = static_cast<int>(std::min_element(global.begin(), global.end()) - global.begin());
  double gpos = kb;
  if (kb > 0 && kb < N - 1) {
    const double a = global[kb - 1], b = global[kb], d = global[kb + 1];
    const double den = a - 2 * b + d;
    if (den > 0) gpos += std::clamp(0.5 * (a - d) / den, -0.5, 0.5);
  }
  out.single_q = q_max_ * gpos / (N - 1);
  out.single = plane_at_inverse_depth(*rig_, out.single_q);

  // Unary costs per tile: candidates 0..N-1 and label N, the single plane.
  const int L = N + 1;
  const double min_count = 0.5 * static_cast<double>(aw) * ah / tiles;
  std::vector<double> unary(static_cast<size_t>(tiles) * L, 0.0);
  out.textured.assign(tiles, false);
  for (int r = 0; r < rows; ++r)
    for (int q = 0; q < cols; ++q) {
      const int t = r * cols + q;
      std::vector<double> agg(N);
      bool seen = true;
      for (int k = 0; k < N && seen; ++k) {
        double s = 0, n = 0;
        for (int dr = -1; dr <= 1; ++dr)
          for (int dq = -1; dq <= 1; ++dq) {
            const int rr = r + dr, qq = q + dq;
            if (rr < 0 || qq < 0 || rr >= rows || qq >= cols) continue;
            s += c.sum[k * tiles + rr * cols + qq];
            n += c.count[k * tiles + rr * cols + qq];
          }
        if (n < min_count) seen = false;
        agg[k] = n > 0 ? s / n : 0.0;
      }
      if (!seen) continue;  // no information: neighbours decide, the tile keeps the single plane
      const auto [lo, hi] = std::minmax_element(agg.begin(), agg.end());
      if (*hi - *lo < opt_.min_texture) continue;
      out.textured[t] = true;
      double* u = &unary[static_cast<size_t>(t) * L];
      for (int k = 0; k < N; ++k) u[k] = agg[k] + opt_.leave_penalty;
      const int g0 = std::min(static_cast<int>(gpos), N - 2);
      const double f = gpos - g0;
      u[N] = (1 - f) * agg[g0] + f * agg[g0 + 1];
    }

  // Semi-global matching over the tile grid, 4 directions.
  auto pos = [&](int l) { return l == N ? gpos : static_cast<double>(l); };
  std::vector<double> pen(static_cast<size_t>(L) * L);
  for (int a = 0; a < L; ++a)
    for (int b = 0; b < L; ++b) {
      const double d = std::abs(pos(a) - pos(b));
      pen[a * L + b] = a == b ? 0.0 : d <= 1.0 ? opt_.step_penalty : opt_.jump_penalty;
    }
  std::vector<double> total(unary.size(), 0.0), path(unary.size());
  const int dirs[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  for (const auto& dir : dirs) {
    const int dq = dir[0], dr = dir[1];
    // Visit tiles so that the predecessor (r - dr, q - dq) comes first.
    for (int ri = 0; ri < rows; ++ri)
      for (int qi = 0; qi < cols; ++qi) {
        const int r = dr < 0 ? rows - 1 - ri : ri, q = dq < 0 ? cols - 1 - qi : qi;
        const int t = r * cols + q;
        const int pr = r - dr, pq = q - dq;
        double* cur = &path[static_cast<size_t>(t) * L];
        const double* u = &unary[static_cast<size_t>(t) * L];
        if (pr < 0 || pq < 0 || pr >= rows || pq >= cols) {
          std::copy(u, u + L, cur);
        } else {
          const double* prev = &path[static_cast<size_t>(pr * cols + pq) * L];
          const double pmin = *std::min_element(prev, prev + L);
          for (int a = 0; a < L; ++a) {
            double best = std::numeric_limits<double>::infinity();
            for (int b = 0; b < L; ++b) best = std::min(best, prev[b] + pen[a * L + b]);
            cur[a] = u[a] + best - pmin;
          }
        }
        for (int a = 0; a < L; ++a) total[static_cast<size_t>(t) * L + a] += cur[a];
      }
  }

  // Labels -> planes (index 0: the single plane).
  std::vector<int> plane_of_label(L, -1);
  FocalSurface fs;
  fs.tile = T, fs.cols = cols, fs.rows = rows;
  fs.planes.push_back(out.single);
  plane_of_label[N] = 0;
  fs.plane_of.assign(tiles, 0);
  out.tile_q.assign(tiles, out.single_q);
  for (int t = 0; t < tiles; ++t) {
    if (!out.textured[t]) continue;
    const double* s = &total[static_cast<size_t>(t) * L];
    const int l = static_cast<int>(std::min_element(s, s + L) - s);
    if (plane_of_label[l] < 0) {
      plane_of_label[l] = static_cast<int>(fs.planes.size());
      fs.planes.push_back(plane_at_inverse_depth(*rig_, candidate_q(l)));
    }
    fs.plane_of[t] = static_cast<uint8_t>(plane_of_label[l]);
    out.tile_q[t] = l == N ? out.single_q : candidate_q(l);
  }
  out.planes_used = fs.planes_used();
  if (fs.planes.size() > 1) out.surface = std::move(fs);
  return out;
}

void apply(const SurfaceEstimate& e, ViewRequest& req) {
  req.focal_plane = e.single;
  req.surface = e.surface;
}

}  // namespace lf
