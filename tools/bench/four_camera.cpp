#include "bench/four_camera.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <opencv2/core.hpp>
#include <stdexcept>

#include "lf/focus/focal_surface.h"
#include "lf/quality/quality.h"
#include "lf/render/render_view.h"

namespace lfbench {

lf::Rig flip_cell_diagonals(const lf::Rig& rig) {
  const auto& pos = rig.plane_positions();
  auto at = [&](int id) { return pos[rig.index_of(id)]; };
  // Longest edge of each triangle, as (smaller id, larger id).
  std::map<std::pair<int, int>, std::vector<int>> by_edge;
  for (size_t t = 0; t < rig.triangles.size(); ++t) {
    const auto& tri = rig.triangles[t];
    int best = 0;
    double longest = -1;
    for (int k = 0; k < 3; ++k) {
      const double len = cv::norm(at(tri[k]) - at(tri[(k + 1) % 3]));
      if (len > longest) longest = len, best = k;
    }
    const int a = tri[best], b = tri[(best + 1) % 3];
    by_edge[{std::min(a, b), std::max(a, b)}].push_back(static_cast<int>(t));
  }
  lf::Rig out = rig;
  out.triangles.clear();
  std::vector<bool> done(rig.triangles.size(), false);
  for (const auto& [edge, tris] : by_edge) {
    if (tris.size() != 2) continue;
    int opp[2] = {-1, -1};
    for (int k = 0; k < 2; ++k)
      for (int id : rig.triangles[tris[k]])
        if (id != edge.first && id != edge.second) opp[k] = id;
    out.triangles.push_back({edge.first, opp[0], opp[1]});
    out.triangles.push_back({edge.second, opp[1], opp[0]});
    done[tris[0]] = done[tris[1]] = true;
  }
  for (size_t t = 0; t < rig.triangles.size(); ++t)
    if (!done[t]) out.triangles.push_back(rig.triangles[t]);
  out.finalize();  // orients the triangles; throws if one folds over
  return out;
}

void four_camera_table(const lf::Rig& rig, const std::vector<cv::Mat>& images, int W, int H) {
  if (rig.grid.rows < 3 || rig.grid.cols < 3)
    throw std::invalid_argument("--four-camera needs a grid of at least 3x3 cameras");
  std::vector<int> drop, held, centre;  // centre: 1 for a cell-centre view
  const int rmax = (rig.grid.rows - 1) / 2 * 2, cmax = (rig.grid.cols - 1) / 2 * 2;
  for (int r = 0; r < rig.grid.rows; ++r)
    for (int c = 0; c < rig.grid.cols; ++c) {
      const int i = rig.grid.at(r, c);
      if (i < 0 || (r % 2 == 0 && c % 2 == 0)) continue;
      drop.push_back(i);
      if (r > rmax || c > cmax) continue;
      held.push_back(i);
      centre.push_back(r % 2 == 1 && c % 2 == 1);
    }
  const lf::Rig a = rig.without(drop), b = flip_cell_diagonals(a);
  std::vector<cv::Mat> kept;
  for (size_t i = 0; i < images.size(); ++i)
    if (std::find(drop.begin(), drop.end(), static_cast<int>(i)) == drop.end())
      kept.push_back(images[i]);
  lf::SurfaceOptions opt;
  opt.second_planes = true;
  const lf::FocalSurfaceEstimator surf(a, kept, opt);
  double sum[2][3] = {}, n[2] = {};
  for (size_t k = 0; k < held.size(); ++k) {
    const int j = held[k];
    lf::ViewRequest req;
    req.view = lf::VirtualView::from_camera(rig.cameras[j], W, H);
    lf::apply(surf.estimate(req), req);
    const cv::Mat gt = lf::camera_view_image(rig.cameras[j], images[j], W, H);
    const cv::Mat ia = lf::render_view(a, kept, req), ib = lf::render_view(b, kept, req);
    cv::Mat mean;
    cv::addWeighted(ia, 0.5, ib, 0.5, 0, mean);
    const int c = centre[k];
    sum[c][0] += lf::psnr(ia, gt, H / 40);
    sum[c][1] += lf::psnr(ib, gt, H / 40);
    sum[c][2] += lf::psnr(mean, gt, H / 40);
    n[c] += 1;
  }
  std::printf(
      "\n## Four-camera weights on %s (in-between views from the sub-grid of even rows and "
      "columns, %dx%d, default focal surface, bilinear sampling; border 2.5%% of the height "
      "cut)\n\n| views | count | PSNR dB, the rig's diagonal | the other diagonal | both "
      "averaged (four-camera weights) | gain over the rig's |\n|---|---|---|---|---|---|\n",
      rig.name.c_str(), W, H);
  const char* names[2] = {"on a cell edge (odd row or column)", "cell centre (odd row and column)"};
  for (int c = 1; c >= 0; --c) {
    if (n[c] == 0) continue;
    std::printf("| %s | %.0f | %.2f | %.2f | %.2f | %+.2f dB |\n", names[c], n[c], sum[c][0] / n[c],
                sum[c][1] / n[c], sum[c][2] / n[c], (sum[c][2] - sum[c][0]) / n[c]);
  }
  const double all = n[0] + n[1];
  std::printf("| all | %.0f | %.2f | %.2f | %.2f | %+.2f dB |\n", all,
              (sum[0][0] + sum[1][0]) / all, (sum[0][1] + sum[1][1]) / all,
              (sum[0][2] + sum[1][2]) / all, (sum[0][2] + sum[1][2] - sum[0][0] - sum[1][0]) / all);
}

}  // namespace lfbench
