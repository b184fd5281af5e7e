#include "helpers.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <vector>

#include "lf/quality/quality.h"
#include "lf/render/render_view.h"

namespace testing_lf {

lf::ViewRequest look_request(const cv::Vec3d& eye, const cv::Vec3d& target, double vfov,
                             const lf::FocalPlane& plane, int w, int h) {
  lf::ViewRequest r;
  r.view = lf::VirtualView::look_at(eye, target, {0, 1, 0}, vfov, w, h);
  r.focal_plane = plane;
  return r;
}

lf::FocalPlane plane_z(double z) {
  return lf::FocalPlane::through({0, 0, z}, {0, 0, 1});
}

std::string data_path(const std::string& rel) {
  // The environment (set by meson test) wins over the compiled-in default.
  const char* env = std::getenv("LF_SHARED_DATA");
  return std::string(env && *env ? env : LF_SHARED_DATA) + "/" + rel;
}

bool have_data(const std::string& dataset) {
  std::error_code ec;
  return std::filesystem::is_directory(data_path(dataset), ec);
}

WeightCheck check_weights(const lf::Rig& rig, const lf::ViewRequest& req) {
  const lf::ViewGeometry g(rig, req);
  const int W = g.width(), H = g.height();
  WeightCheck c;
  std::vector<lf::ApertureSample> loc(static_cast<size_t>(W) * H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) loc[static_cast<size_t>(y) * W + x] = g.locate(x, y);
  std::vector<double> sum(loc.size(), 0.0), expect_sum(loc.size(), 0.0);
  std::vector<int> mark(loc.size(), 0);
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const lf::FragmentPlan plan = lf::plan_fragment(g, static_cast<int>(i));
    std::fill(mark.begin(), mark.end(), 0);
    for (const lf::Run& r : plan.runs) {
      const lf::FragmentPiece& pc = plan.pieces[r.piece];
      for (int x = r.x0; x < r.x1; ++x) {
        const double w = pc.weight_num(x, r.y) / pc.weight_den(x, r.y);
        if (!std::isfinite(w)) c.finite = false;
        c.min_weight = std::min(c.min_weight, w);
        c.max_weight = std::max(c.max_weight, w);
        const size_t k = static_cast<size_t>(r.y) * W + x;
        sum[k] += w;
        if (mark[k]++) c.overlaps++;
      }
    }
    c.fragment_pixels += plan.pixel_count();
    int x0 = W, y0 = H, x1 = -1, y1 = -1;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const size_t k = static_cast<size_t>(y) * W + x;
        bool expected = false;
        for (int j = 0; j < loc[k].count; ++j)
          if (loc[k].cams[j] == static_cast<int>(i) && loc[k].weight[j] > 0) {
            if (g.visible(static_cast<int>(i), x, y)) {
              expected = true;
              expect_sum[k] += loc[k].weight[j];
            } else {
              c.invisible++;
            }
          }
        if (expected != (mark[k] > 0)) c.coverage_mismatch++;
        if (expected)
          x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
      }
    const cv::Rect expect_rect = x1 >= 0 ? cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1) : cv::Rect();
    if (expect_rect != plan.rect) c.rect_mismatch++;
  }
  for (size_t k = 0; k < loc.size(); ++k) {
    if (loc[k].simplex >= 0) {
      c.seen++;
      c.max_sum_error = std::max(c.max_sum_error, std::abs(sum[k] - expect_sum[k]));
    } else {
      c.unseen++;
      c.max_unseen_sum = std::max(c.max_unseen_sum, sum[k]);
    }
  }
  return c;
}

void expect_valid(const WeightCheck& c, const std::string& what, bool all_visible) {
  SCOPED_TRACE(what);
  EXPECT_TRUE(c.finite);
  EXPECT_EQ(c.overlaps, 0u);
  EXPECT_EQ(c.coverage_mismatch, 0u);
  EXPECT_EQ(c.rect_mismatch, 0u);
  if (c.fragment_pixels > 0) {
    EXPECT_GE(c.min_weight, 0.0);
    EXPECT_LE(c.max_weight, 1.0 + 1e-12);
  }
  EXPECT_LE(c.max_sum_error, 1e-9);
  EXPECT_EQ(c.max_unseen_sum, 0.0);
  if (all_visible) {
    EXPECT_EQ(c.invisible, 0u);
  }
}

Held hold_out(const lf::Rig& rig, const std::vector<cv::Mat>& images, int j, int W, int H) {
  Held h;
  h.rig = rig.without({j});
  for (size_t i = 0; i < images.size(); ++i)
    if (static_cast<int>(i) != j) h.images.push_back(images[i]);
  h.req.view = lf::VirtualView::from_camera(rig.cameras[j], W, H);
  h.truth = lf::camera_view_image(rig.cameras[j], images[j], W, H);
  return h;
}

double psnr_at(const Held& h, const lf::FocalPlane& p) {
  lf::ViewRequest r = h.req;
  r.focal_plane = p;
  return lf::psnr(lf::render_view(h.rig, h.images, r), h.truth, r.view.height / 40);
}

}  // namespace testing_lf
