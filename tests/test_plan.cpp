// Fragment planning: homography vs brute-force ray casting, weights in [0,1]
// summing to 1 wherever the view sees the camera surface, fragment runs and
// rectangles exactly the pixels with nonzero weight.
#include <gtest/gtest.h>

#include <random>

#include "helpers.h"
#include "lf/plan.h"
#include "lf/synthetic.h"

namespace {

using testing_lf::check_weights;
using testing_lf::expect_valid;

lf::ViewRequest random_request(const lf::Rig& rig, std::mt19937_64& rng, int W, int H,
                               bool on_plane) {
  std::uniform_real_distribution<double> u(-1, 1);
  lf::ViewRequest req;
  const cv::Vec3d eye(1.5 * u(rng), 1.5 * u(rng), on_plane ? 0.0 : 2.0 * u(rng));
  const cv::Vec3d target(3 * u(rng), 3 * u(rng), 10 + 5 * u(rng));
  req.view = lf::VirtualView::look_at(eye, target, {0, 1, 0}, 30 + 25 * (u(rng) + 1), W, H);
  const cv::Vec3d n = cv::Vec3d(0.3 * u(rng), 0.3 * u(rng), 1.0);
  req.focal_plane = lf::FocalPlane::through({0, 0, 8 + 4 * u(rng)}, n);
  (void)rig;
  return req;
}

TEST(Plan, HomographyMatchesRayCasting) {
  lf::Rig rig = lf::synthetic_grid_rig(5, 5, 0.5, 320, 240, 45, 2.0, 9);
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> px(0, 640), py(0, 480);
  double worst = 0;
  int checked = 0;
  for (int v = 0; v < 40; ++v) {
    const lf::ViewRequest req = random_request(rig, rng, 640, 480, v % 2 == 0);
    const lf::ViewGeometry g(rig, req);
    const cv::Vec3d E = req.view.position;
    const lf::FocalPlane& fp = req.focal_plane;
    for (size_t i = 0; i < rig.cameras.size(); ++i) {
      const lf::Camera& cam = rig.cameras[i];
      for (int k = 0; k < 50; ++k) {
        const double x = px(rng), y = py(rng);
        const cv::Vec3d D = g.ray(x, y);
        const double t = -(fp.n.dot(E) + fp.d) / fp.n.dot(D);
        const cv::Vec3d F = E + D * t;
        const auto expect = cam.project(F);
        const bool vis = g.visible(static_cast<int>(i), x, y);
        EXPECT_EQ(vis, expect.has_value());
        if (!expect || cv::norm(*expect) > 1e5) continue;
        const cv::Vec3d h = g.homography(static_cast<int>(i)) * cv::Vec3d(x, y, 1);
        worst = std::max(worst, cv::norm(cv::Vec2d(h[0] / h[2], h[1] / h[2]) - *expect));
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 10000);
  EXPECT_LE(worst, 0.01);
  EXPECT_LE(worst, 1e-6) << "double-precision homography should be far better than 0.01 px";
}

TEST(Plan, SingleCameraGeometryPlansTheSameFragment) {
  lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.5, 160, 120, 45, 2.0, 11);
  std::mt19937_64 rng(12);
  for (int v = 0; v < 6; ++v) {
    const lf::ViewRequest req = random_request(rig, rng, 96, 72, v % 2 == 0);
    const lf::ViewGeometry all(rig, req);
    for (int i : {0, 5, 15}) {
      const lf::ViewGeometry one(rig, req, i);
      EXPECT_EQ(one.homography(i), all.homography(i));
      const auto a = lf::plan_fragment(all, i), b = lf::plan_fragment(one, i);
      EXPECT_EQ(a.rect, b.rect);
      EXPECT_EQ(a.runs.size(), b.runs.size());
      EXPECT_EQ(a.pixel_count(), b.pixel_count());
    }
  }
}

TEST(Plan, WeightsPartitionUnityOnRandomViews) {
  lf::Rig rig = lf::synthetic_grid_rig(4, 5, 0.5, 160, 120, 45, 2.0, 3);
  std::mt19937_64 rng(7);
  size_t seen = 0;
  for (int v = 0; v < 16; ++v) {
    const lf::ViewRequest req = random_request(rig, rng, 96, 72, v % 3 == 0);
    const auto c = check_weights(rig, req);
    expect_valid(c, "random view " + std::to_string(v));
    seen += c.seen;
  }
  EXPECT_GT(seen, 20000u) << "the random views should mostly see the camera surface";
}

TEST(Plan, WeightsArePerspectiveCorrectBarycentrics) {
  // Eye off the camera plane: the weight at a pixel equals the barycentric
  // coordinate of its line's intersection with the camera plane.
  lf::Rig rig = lf::synthetic_grid_rig(3, 3, 1.0, 160, 120, 45);
  lf::ViewRequest req;
  req.view = lf::VirtualView::look_at({0.2, -0.1, -2.0}, {0.5, 0.3, 10}, {0, 1, 0}, 60, 200, 150);
  req.focal_plane = lf::FocalPlane::through({0, 0, 10}, {0, 0, 1});
  const lf::ViewGeometry g(rig, req);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> px(0, 199), py(0, 149);
  int n = 0;
  for (int k = 0; k < 2000; ++k) {
    const double x = px(rng), y = py(rng);
    const auto s = g.locate(x, y);
    if (s.simplex < 0) continue;
    const cv::Vec3d D = g.ray(x, y), E = req.view.position;
    const cv::Vec3d X = E + D * (-E[2] / D[2]);
    // Barycentrics of X in the triangle (independent computation).
    const cv::Vec3d A = rig.cameras[s.cams[0]].center(), B = rig.cameras[s.cams[1]].center(),
                    C = rig.cameras[s.cams[2]].center();
    const cv::Matx22d M(B[0] - A[0], C[0] - A[0], B[1] - A[1], C[1] - A[1]);
    const cv::Vec2d bc = M.inv() * cv::Vec2d(X[0] - A[0], X[1] - A[1]);
    EXPECT_NEAR(s.weight[1], bc[0], 1e-9);
    EXPECT_NEAR(s.weight[2], bc[1], 1e-9);
    EXPECT_NEAR(s.weight[0], 1 - bc[0] - bc[1], 1e-9);
    ++n;
  }
  EXPECT_GT(n, 500);
}

TEST(Plan, FragmentPixelsAreAboutThreeTimesTheOutput) {
  // Eye off the plane, view seeing only the camera surface: every pixel gets
  // exactly three cameras (fragment pixels == 3 x seen pixels up to edges).
  lf::Rig rig = lf::synthetic_grid_rig(8, 8, 0.1, 160, 120, 40);
  lf::ViewRequest req;
  req.view = lf::VirtualView::look_at({0.01, 0.02, 0.3}, {0.05, 0.0, 10}, {0, 1, 0}, 40, 128, 96);
  req.focal_plane = lf::FocalPlane::through({0, 0, 10}, {0, 0, 1});
  const auto c = check_weights(rig, req);
  expect_valid(c, "dense view");
  EXPECT_EQ(c.unseen, 0u);
  EXPECT_NEAR(static_cast<double>(c.fragment_pixels) / c.seen, 3.0, 0.05);
}

}  // namespace
