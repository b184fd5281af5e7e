// Fragment planning: homography vs brute-force ray casting, weights in [0,1]
// summing to 1 wherever the view sees the camera surface, fragment runs and
// rectangles exactly the pixels with nonzero weight.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>

#include "helpers.h"
#include "lf/focus/focus.h"
#include "lf/quality/quality.h"
#include "lf/quality/synthetic.h"
#include "lf/render/plan.h"
#include "lf/render/render_view.h"

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

// A surface of random planes over tiles of 8 pixels (the last column and
// row narrower): every pixel is planned through its own tile's plane, the
// weights still partition unity, and each run's homography is its tile's.
lf::ViewRequest with_random_surface(lf::ViewRequest req, std::mt19937_64& rng, int planes) {
  std::uniform_real_distribution<double> u(-1, 1);
  lf::FocalSurface& fs = req.surface;
  fs.tile = 8;
  fs.cols = (req.view.width + 7) / 8;
  fs.rows = (req.view.height + 7) / 8;
  for (int k = 0; k < planes; ++k)
    fs.planes.push_back(
        lf::FocalPlane::through({0, 0, 6 + 8 * (u(rng) + 1)}, {0.2 * u(rng), 0.2 * u(rng), 1.0}));
  std::uniform_int_distribution<int> pick(0, planes - 1);
  for (int k = 0; k < fs.cols * fs.rows; ++k) fs.plane_of.push_back(pick(rng));
  return req;
}

TEST(Plan, FocalSurfaceTilesArePlannedThroughTheirOwnPlanes) {
  lf::Rig rig = lf::synthetic_grid_rig(4, 5, 0.5, 160, 120, 45, 2.0, 3);
  std::mt19937_64 rng(21);
  size_t runs_checked = 0;
  for (int v = 0; v < 10; ++v) {
    const lf::ViewRequest req =
        with_random_surface(random_request(rig, rng, 100, 75, v % 3 == 0), rng, 1 + v % 4);
    const auto c = check_weights(rig, req);  // visibility through each pixel's plane
    expect_valid(c, "surface view " + std::to_string(v));
    const lf::ViewGeometry g(rig, req);
    for (size_t i = 0; i < rig.cameras.size(); ++i) {
      const lf::FragmentPlan plan = lf::plan_fragment(g, static_cast<int>(i));
      for (const lf::Run& r : plan.runs) {
        const cv::Matx33d& P = plan.pieces[r.piece].H;
        for (int x : {r.x0, r.x1 - 1}) {
          // The piece's homography is the tile's, up to a positive scale.
          const cv::Vec3d a = P * cv::Vec3d(x, r.y, 1);
          const cv::Vec3d b = g.homography_at(static_cast<int>(i), x, r.y) * cv::Vec3d(x, r.y, 1);
          ASSERT_GT(a[2] * g.focal_sign(x, r.y), 0);
          EXPECT_NEAR(a[0] / a[2], b[0] / b[2], 1e-6 * (1 + std::abs(b[0] / b[2])));
          EXPECT_NEAR(a[1] / a[2], b[1] / b[2], 1e-6 * (1 + std::abs(b[1] / b[2])));
          // A run never crosses a tile edge where the plane changes.
          EXPECT_EQ(g.plane_at(x, r.y), g.plane_at(r.x0, r.y));
        }
        ++runs_checked;
      }
    }
  }
  EXPECT_GT(runs_checked, 1000u);
}

TEST(Plan, OnePlaneSurfacePlansTheSinglePlanesFragment) {
  // The model grows only with the scene: a surface whose tiles all name the
  // request's plane plans exactly the single-plane fragment.
  lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.5, 160, 120, 45, 2.0, 11);
  std::mt19937_64 rng(5);
  for (int v = 0; v < 6; ++v) {
    lf::ViewRequest req = random_request(rig, rng, 90, 70, v % 2 == 0);
    lf::ViewRequest surf = req;
    surf.surface.tile = 16;
    surf.surface.cols = 6, surf.surface.rows = 5;
    surf.surface.planes = {lf::FocalPlane::through({0, 0, 30}, {0, 0, 1}), req.focal_plane};
    surf.surface.plane_of.assign(30, 1);
    EXPECT_EQ(surf.surface.planes_used(), 1);
    const lf::ViewGeometry a(rig, req), b(rig, surf);
    for (int i = 0; i < 16; ++i) {
      const auto pa = lf::plan_fragment(a, i), pb = lf::plan_fragment(b, i);
      ASSERT_EQ(pa.runs.size(), pb.runs.size());
      for (size_t k = 0; k < pa.runs.size(); ++k) {
        EXPECT_EQ(pa.runs[k].y, pb.runs[k].y);
        EXPECT_EQ(pa.runs[k].x0, pb.runs[k].x0);
        EXPECT_EQ(pa.runs[k].x1, pb.runs[k].x1);
      }
      ASSERT_EQ(pa.pieces.size(), pb.pieces.size());
      for (size_t k = 0; k < pa.pieces.size(); ++k) EXPECT_EQ(pa.pieces[k].H, pb.pieces[k].H);
    }
  }
}

TEST(Plan, TwoPlaneTilesSendTheNearerPlaneInLayerOne) {
  // A surface with second planes in some tiles: layer 1 holds exactly the
  // pixels and homographies that the camera's fragment has in those tiles
  // through the nearer of their two planes, layer 0 those of every tile
  // through its other plane.
  lf::Rig rig = lf::synthetic_grid_rig(4, 5, 0.5, 160, 120, 45, 2.0, 3);
  std::mt19937_64 rng(33);
  size_t pixels = 0;
  int nearer_second = 0, nearer_first = 0;
  for (int v = 0; v < 8; ++v) {
    lf::ViewRequest req =
        with_random_surface(random_request(rig, rng, 100, 75, v % 3 == 0), rng, 3);
    lf::FocalSurface& fs = req.surface;
    fs.second_of.assign(fs.plane_of.size(), lf::FocalSurface::kNone);
    for (size_t t = 0; t < fs.plane_of.size(); ++t)
      if (rng() % 3 == 0) fs.second_of[t] = static_cast<uint8_t>((fs.plane_of[t] + 1) % 3);
    const lf::ViewGeometry g(rig, req);
    // Each layer's planes as a one-plane-per-tile surface, the nearer found
    // here independently: the smaller positive distance along the ray of
    // the tile's centre pixel.
    lf::ViewRequest near = req, far = req;
    near.surface.second_of.clear(), far.surface.second_of.clear();
    std::vector<bool> two(fs.plane_of.size());
    for (int r = 0; r < fs.rows; ++r)
      for (int c = 0; c < fs.cols; ++c) {
        const int t = r * fs.cols + c;
        two[t] = fs.second_of[t] != lf::FocalSurface::kNone;
        if (!two[t]) continue;
        const double x = (std::min(100, (c + 1) * fs.tile) + c * fs.tile - 1) * 0.5;
        const double y = (std::min(75, (r + 1) * fs.tile) + r * fs.tile - 1) * 0.5;
        const cv::Vec3d D = g.ray(x, y), E = req.view.position;
        auto along = [&](int p) {
          const lf::FocalPlane& q = fs.planes[p];
          const double d = -(q.n.dot(E) + q.d) / q.n.dot(D);
          return d > 0 ? d : INFINITY;
        };
        const bool second_near = along(fs.second_of[t]) < along(fs.plane_of[t]);
        (second_near ? nearer_second : nearer_first)++;
        near.surface.plane_of[t] = second_near ? fs.second_of[t] : fs.plane_of[t];
        far.surface.plane_of[t] = second_near ? fs.plane_of[t] : fs.second_of[t];
        EXPECT_EQ(g.layer_plane(1, t), near.surface.plane_of[t]);
        EXPECT_EQ(g.layer_plane(0, t), far.surface.plane_of[t]);
      }
    const lf::ViewGeometry gn(rig, near), gf(rig, far);
    for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i) {
      // (y, x) -> homography of that pixel, per plan.
      auto pixel_map = [&](const lf::FragmentPlan& p, bool only_two) {
        std::map<std::pair<int, int>, cv::Matx33d> m;
        for (const lf::Run& r : p.runs)
          for (int x = r.x0; x < r.x1; ++x)
            if (!only_two || two[(r.y / fs.tile) * fs.cols + x / fs.tile])
              m[{r.y, x}] = p.pieces[r.piece].H;
        return m;
      };
      const auto layers = lf::plan_fragment_layers(g, i);
      EXPECT_EQ(layers[0].layer, 0);
      EXPECT_EQ(layers[1].layer, 1);
      // A camera's own geometry given the tiling of the whole rig's (as
      // cameras in one process share it, lf::shared_geometry) plans the
      // same runs through the same homographies.
      const lf::ViewGeometry own(rig, req, i, nullptr, g.surface_layout());
      EXPECT_EQ(own.surface_layout(), g.surface_layout());
      const auto own_layers = lf::plan_fragment_layers(own, i);
      for (int l = 0; l < 2; ++l) {
        ASSERT_EQ(own_layers[l].runs.size(), layers[l].runs.size());
        for (size_t r = 0; r < layers[l].runs.size(); ++r) {
          const lf::Run &a = layers[l].runs[r], &b = own_layers[l].runs[r];
          EXPECT_TRUE(a.y == b.y && a.x0 == b.x0 && a.x1 == b.x1);
          EXPECT_EQ(layers[l].pieces[a.piece].H, own_layers[l].pieces[b.piece].H);
        }
      }
      for (int l = 0; l < 2; ++l) {
        const auto got = pixel_map(layers[l], false);
        const auto alone = pixel_map(lf::plan_fragment(g, i, l), false);
        const auto expect = pixel_map(lf::plan_fragment(l ? gn : gf, i, 0), l == 1);
        ASSERT_EQ(got.size(), expect.size()) << "view " << v << " camera " << i << " layer " << l;
        EXPECT_EQ(got.size(), alone.size());
        for (const auto& [at, H] : got) {
          const auto it = expect.find(at);
          ASSERT_TRUE(it != expect.end());
          EXPECT_EQ(H, it->second);
        }
        if (l == 1) pixels += got.size();
      }
    }
  }
  EXPECT_GT(pixels, 10000u);
  EXPECT_GT(nearer_second, 20);  // both orders occur
  EXPECT_GT(nearer_first, 20);
  // A tiling of another size, or of another output size, is not taken.
  {
    lf::ViewRequest req = with_random_surface(random_request(rig, rng, 100, 75, false), rng, 3);
    for (const uint8_t p : req.surface.plane_of)
      req.surface.second_of.push_back(static_cast<uint8_t>((p + 1) % 3));
    const lf::ViewGeometry g(rig, req);
    for (int odd = 0; odd < 3; ++odd) {
      auto layout = std::make_shared<lf::SurfaceLayout>(*g.surface_layout());
      (odd == 0 ? layout->cols : odd == 1 ? layout->width : layout->height) += 1;
      layout->regions = {};
      const lf::ViewGeometry own(rig, req, 2, nullptr, layout);
      EXPECT_NE(own.surface_layout(), layout);
      EXPECT_EQ(own.regions(0).size(), g.regions(0).size());
      EXPECT_EQ(own.regions(1).size(), g.regions(1).size());
      EXPECT_GT(g.regions(1).size(), 0u);
    }
  }
  // Without second planes, layer 1 is empty.
  const lf::ViewRequest plain =
      with_random_surface(random_request(rig, rng, 64, 48, false), rng, 2);
  EXPECT_TRUE(lf::plan_fragment(lf::ViewGeometry(rig, plain), 0, 1).empty());
}

bool validity_throws(const lf::ViewRequest& r) {
  try {
    lf::validate(r);
  } catch (const std::invalid_argument&) {
    return true;
  }
  return false;
}

TEST(Plan, MalformedSurfacesAreRefused) {
  lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 45, 2.0, 1);
  std::mt19937_64 rng(9);
  const lf::ViewRequest good = with_random_surface(random_request(rig, rng, 64, 48, false), rng, 2);
  EXPECT_NO_THROW(lf::validate(good));
  auto refused = [&](auto mutate, const char* what) {
    lf::ViewRequest r = good;
    mutate(r.surface);
    EXPECT_THROW(lf::validate(r), std::invalid_argument) << what;
  };
  refused([](lf::FocalSurface& s) { s.tile = 2; }, "tile too small");
  refused([](lf::FocalSurface& s) { s.cols += 1; }, "grid does not match");
  refused([](lf::FocalSurface& s) { s.plane_of.pop_back(); }, "missing tile");
  refused([](lf::FocalSurface& s) { s.plane_of[3] = 2; }, "plane out of range");
  refused([](lf::FocalSurface& s) { s.planes.clear(); }, "no planes");
  refused([](lf::FocalSurface& s) { s.planes[0].d = NAN; }, "not finite");
  refused([](lf::FocalSurface& s) { s.planes[1] = {{0, 0, 0}, 0.0}; }, "not a plane");
  refused([](lf::FocalSurface& s) { s.planes.resize(lf::FocalSurface::kMaxPlanes + 1); },
          "too many planes");
  refused([](lf::FocalSurface& s) { s.second_of.assign(s.plane_of.size() - 1, 1); },
          "second planes: missing tile");
  refused(
      [](lf::FocalSurface& s) {
        s.second_of.assign(s.plane_of.size(), lf::FocalSurface::kNone);
        s.second_of[0] = s.plane_of[0];
      },
      "second plane is the first");
  refused(
      [](lf::FocalSurface& s) {
        s.second_of.assign(s.plane_of.size(), lf::FocalSurface::kNone);
        s.second_of[0] = 7;
      },
      "second plane out of range");
  lf::ViewRequest ok = good;
  ok.surface.second_of.assign(ok.surface.plane_of.size(), lf::FocalSurface::kNone);
  ok.surface.second_of[0] = static_cast<uint8_t>(1 - ok.surface.plane_of[0]);
  EXPECT_NO_THROW(lf::validate(ok));
  EXPECT_EQ(ok.surface.two_plane_tiles(), 1);
  // A bad entry in any tile (the tiles are checked sixteen at a time, then
  // one by one): each refused, and a good second plane anywhere taken.
  for (const int w : {64, 72}) {  // 48 tiles; 54
    const lf::ViewRequest base =
        with_random_surface(random_request(rig, rng, w, 48, false), rng, 3);
    const size_t tiles = base.surface.plane_of.size();
    ASSERT_GT(tiles, 16u);
    int bad = 0;
    for (size_t t = 0; t < tiles; ++t) {
      lf::ViewRequest r = base;
      r.surface.plane_of[t] = 3;
      bad += !validity_throws(r);
      r = base;
      r.surface.second_of.assign(tiles, lf::FocalSurface::kNone);
      r.surface.second_of[t] = static_cast<uint8_t>((r.surface.plane_of[t] + 1) % 3);
      EXPECT_NO_THROW(lf::validate(r)) << "tile " << t;
      for (const uint8_t k : {r.surface.plane_of[t], uint8_t{3}, uint8_t{0xFE}}) {
        r.surface.second_of[t] = k;
        bad += !validity_throws(r);
      }
    }
    EXPECT_EQ(bad, 0) << tiles << " tiles, " << (tiles % 16) << " past the last sixteen";
  }
}

}  // namespace

// Camera i's tent on a rig on z = 0: its barycentric coordinate in the
// triangles of the rig's triangulation that hold it (independent of the
// planner's facet forms).
struct Tent {
  struct Tri {
    cv::Matx22d inv;  // plane point - c0 -> barycentrics of vertices 1, 2
    cv::Vec2d c0;
    int slot;
  };
  std::vector<Tri> star;
  Tent(const lf::Rig& rig, int i) {
    for (const auto& tri : rig.triangles) {
      int slot = -1;
      std::array<cv::Vec3d, 3> c;
      for (int k = 0; k < 3; ++k) {
        const int idx = rig.index_of(tri[k]);
        c[k] = rig.cameras[idx].center();
        if (idx == i) slot = k;
      }
      if (slot < 0) continue;
      const cv::Matx22d M(c[1][0] - c[0][0], c[2][0] - c[0][0], c[1][1] - c[0][1],
                          c[2][1] - c[0][1]);
      star.push_back({M.inv(), {c[0][0], c[0][1]}, slot});
    }
  }
  // The weight at plane point (x, y).
  double operator()(double x, double y) const {
    double best = 0;
    for (const Tri& t : star) {
      const cv::Vec2d bc = t.inv * cv::Vec2d(x - t.c0[0], y - t.c0[1]);
      const std::array<double, 3> b{1 - bc[0] - bc[1], bc[0], bc[1]};
      if (b[0] >= -1e-12 && b[1] >= -1e-12 && b[2] >= -1e-12) best = std::max(best, b[t.slot]);
    }
    return best;
  }
};

TEST(Plan, AWiderApertureIsTheTentScaledAboutEachCamera) {
  // lf/geometry/view.h Aperture: with scale k, camera i's weight where the pixel's
  // line meets the camera plane at X is its tent weight at
  // C_i + (X - C_i) / k. Checked at every pixel of every camera's fragment
  // (the planned piece's num / den) and for coverage (the runs are exactly
  // the pixels with a positive reference weight that the camera sees).
  lf::Rig rig = lf::synthetic_grid_rig(5, 5, 1.0, 160, 120, 45);
  std::mt19937_64 rng(11);
  const int W = 96, H = 72;
  size_t weighted_pixels = 0, checked_views = 0;
  for (const double k : {1.0, 2.0, 3.5}) {
    size_t pixels_at_scale = 0;
    for (int trial = 0; trial < 4; ++trial) {
      lf::ViewRequest req = random_request(rig, rng, W, H, trial == 3);
      req.aperture_scale = k;
      const lf::ViewGeometry g(rig, req);
      const cv::Vec3d E = req.view.position;
      for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i) {
        const Tent tent_weight(rig, i);
        const lf::FragmentPlan plan = lf::plan_fragment(g, i);
        std::vector<double> planned(static_cast<size_t>(W) * H, -1);
        for (const lf::Run& r : plan.runs) {
          const lf::FragmentPiece& piece = plan.pieces[r.piece];
          for (int x = r.x0; x < r.x1; ++x)
            planned[static_cast<size_t>(r.y) * W + x] =
                std::clamp(piece.weight_num(x, r.y) / piece.weight_den(x, r.y), 0.0, 1.0);
        }
        const cv::Vec3d C = rig.cameras[i].center();
        size_t wrong_weight = 0, wrong_coverage = 0;
        for (int y = 0; y < H; ++y)
          for (int x = 0; x < W; ++x) {
            const cv::Vec3d D = g.ray(x, y);
            if (E[2] != 0 && D[2] == 0) continue;
            const cv::Vec3d X = E[2] == 0 ? E : E + D * (-E[2] / D[2]);
            const double ref = tent_weight(C[0] + (X[0] - C[0]) / k, C[1] + (X[1] - C[1]) / k);
            const double got = planned[static_cast<size_t>(y) * W + x];
            const bool expect_in = ref > 1e-9 && g.visible(i, x, y);
            if (got >= 0) {
              ++pixels_at_scale;
              if (std::abs(got - ref) > 1e-9) ++wrong_weight;
            }
            // At a support's border (reference weight ~0) either is right.
            if ((got >= 0) != expect_in && ref > 1e-9) ++wrong_coverage;
          }
        EXPECT_EQ(wrong_weight, 0u) << "scale " << k << ", view " << trial << ", camera " << i;
        EXPECT_EQ(wrong_coverage, 0u) << "scale " << k << ", view " << trial << ", camera " << i;
      }
      ++checked_views;
    }
    weighted_pixels += pixels_at_scale;
    std::printf("aperture scale %.1f: %zu fragment pixels over 4 views\n", k, pixels_at_scale);
  }
  EXPECT_EQ(checked_views, 12u);
  EXPECT_GT(weighted_pixels, 50000u);
  // A line of cameras (segments) and a single camera (a point): planned
  // with weights in (0, 1], more cameras than the tent's where it is wider.
  for (const int cols : {5, 1}) {
    const lf::Rig line = lf::synthetic_grid_rig(1, cols, 1.0, 160, 120, 45);
    size_t contributing[2] = {0, 0};
    for (const double k : {1.0, 3.0}) {
      lf::ViewRequest req = random_request(line, rng, W, H, false);
      req.view = lf::VirtualView::look_at({0.3, 0, -1}, {0.3, 0, 10}, {0, 1, 0}, 40, W, H);
      req.aperture_scale = k;
      const lf::ViewGeometry g(line, req);
      for (int i = 0; i < cols; ++i) {
        const lf::FragmentPlan plan = lf::plan_fragment(g, i);
        contributing[k > 1] += !plan.empty();
        for (const lf::Run& r : plan.runs)
          for (int x = r.x0; x < r.x1; ++x) {
            const lf::FragmentPiece& piece = plan.pieces[r.piece];
            const double w = piece.weight_num(x, r.y) / piece.weight_den(x, r.y);
            EXPECT_GT(w, -1e-12);
            EXPECT_LT(w, 1 + 1e-12);
          }
      }
    }
    EXPECT_GE(contributing[0], 1u);
    if (cols > 1) {
      EXPECT_GT(contributing[1], contributing[0]) << "a wider aperture, more cameras";
    }
  }
}

namespace {
// Planned weights of every camera, summed per pixel; `count` cameras per pixel.
// Every weight is in (0, 1] (`positive`) or [0, 1].
std::vector<double> weight_sums(const lf::Rig& rig, const lf::ViewGeometry& g,
                                std::vector<int>* count = nullptr, bool positive = false) {
  const int W = g.width(), H = g.height();
  std::vector<double> sum(static_cast<size_t>(W) * H, 0.0);
  if (count) count->assign(sum.size(), 0);
  for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i) {
    const lf::FragmentPlan plan = lf::plan_fragment(g, i);
    for (const lf::Run& r : plan.runs)
      for (int x = r.x0; x < r.x1; ++x) {
        const lf::FragmentPiece& pc = plan.pieces[r.piece];
        const double w = pc.weight_num(x, r.y) / pc.weight_den(x, r.y);
        EXPECT_GT(w, positive ? 0 : -1e-12) << "camera " << i;
        EXPECT_LE(w, 1 + 1e-12);
        sum[static_cast<size_t>(r.y) * W + x] += w;
        if (count) ++(*count)[static_cast<size_t>(r.y) * W + x];
      }
  }
  return sum;
}

}  // namespace

// ULR weights (lf/geometry/view.h Aperture::kUlr): planned weights sum to 1 at every
// pixel, two cameras or more blend everywhere (so a lost camera leaves no
// hole; k where no penalties tie), where the k nearest tie (the centre of
// a grid cell with k = 4) all k blend equally, and with the eye right over
// a camera its tying neighbours blend too.
TEST(Plan, UlrWeightsSumToOneAndCoverALostCamera) {
  const lf::Rig rig = lf::synthetic_grid_rig(5, 5, 1.0, 160, 120, 60);
  const int W = 129, H = 129;  // vertex (1, 1) is pixel (64, 64), the centre
  for (const int k : {3, 4, 6}) {
    lf::ViewRequest req;
    req.view = lf::VirtualView::look_at({0.5, 0.5, -1.0}, {0.5, 0.5, 10}, {0, 1, 0}, 25, W, H);
    req.focal_plane = lf::FocalPlane::through({0, 0, 10}, {0, 0, 1});
    req.aperture = lf::Aperture::kUlr;
    req.ulr_cameras = k;
    const lf::ViewGeometry g(rig, req);
    ASSERT_EQ(g.ulr_cols(), 3);
    // A camera given the field of another camera's geometry (as cameras in
    // one process share it) plans the same fragment; a field of another
    // size is not taken.
    const lf::ViewGeometry shared(rig, req, 7, g.ulr_field());
    EXPECT_EQ(shared.ulr_field(), g.ulr_field());
    const lf::FragmentPlan a = lf::plan_fragment(g, 7), b = lf::plan_fragment(shared, 7);
    ASSERT_EQ(a.runs.size(), b.runs.size());
    for (size_t r = 0; r < a.runs.size(); ++r)
      EXPECT_TRUE(a.runs[r].y == b.runs[r].y && a.runs[r].x0 == b.runs[r].x0 &&
                  a.runs[r].x1 == b.runs[r].x1);
    auto odd = std::make_shared<lf::UlrField>(*g.ulr_field());
    odd->cols += 1;
    const lf::ViewGeometry own(rig, req, 7, odd);
    EXPECT_NE(own.ulr_field(), odd);
    EXPECT_EQ(own.ulr_field()->w, g.ulr_field()->w);
    std::vector<int> count;
    const std::vector<double> sum = weight_sums(rig, g, &count, true);
    size_t pixels = 0;
    for (const int n : count) pixels += n;
    double worst = 0;
    int fewest = 1 << 20;
    for (size_t p = 0; p < sum.size(); ++p) {
      worst = std::max(worst, std::abs(sum[p] - 1));
      fewest = std::min(fewest, count[p]);
    }
    std::printf("ULR k = %d: %.2f fragment px per output px, |sum - 1| <= %.1e, >= %d cameras\n", k,
                static_cast<double>(pixels) / (W * H), worst, fewest);
    EXPECT_LT(worst, 1e-9) << "k = " << k;
    EXPECT_GE(fewest, 2) << "k = " << k;
    // The view's centre looks through the centre of a grid cell (eye at
    // (0.5, 0.5)): with k = 4 the four corners tie and blend equally there.
    if (k == 4) {
      std::vector<double> w;
      for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i)
        if (g.ulr_weight(i, 1, 1) > 0) w.push_back(g.ulr_weight(i, 1, 1));
      ASSERT_EQ(w.size(), 4u) << "the vertex at pixel (64, 64)";
      for (const double v : w) EXPECT_NEAR(v, 0.25, 1e-9);
    }
  }
  // Through a focal surface of 3 planes in 8-pixel tiles: still 1.
  {
    std::mt19937_64 rng(4);
    lf::ViewRequest req;
    req.view = lf::VirtualView::look_at({0.3, 0.4, -1.0}, {0.5, 0.5, 10}, {0, 1, 0}, 25, W, H);
    req.focal_plane = lf::FocalPlane::through({0, 0, 10}, {0, 0, 1});
    req = with_random_surface(req, rng, 3);
    req.aperture = lf::Aperture::kUlr;
    const lf::ViewGeometry g(rig, req);
    const std::vector<double> sum = weight_sums(rig, g);
    double worst = 0;
    for (const double v : sum) worst = std::max(worst, std::abs(v - 1));
    EXPECT_LT(worst, 1e-9) << "through a focal surface";
  }
  // The eye over camera (2, 2), k = 3: its four neighbours tie for 2nd.
  lf::ViewRequest req;
  req.view = lf::VirtualView::look_at({0, 0, -1.0}, {0, 0, 10}, {0, 1, 0}, 25, W, H);
  req.focal_plane = lf::FocalPlane::through({0, 0, 10}, {0, 0, 1});
  req.aperture = lf::Aperture::kUlr;
  req.ulr_cameras = 3;
  const lf::ViewGeometry g(rig, req);
  int blended = 0;
  for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i)
    blended += g.ulr_weight(i, 1, 1) > 0;
  EXPECT_EQ(blended, 5) << "the camera under the eye and its four neighbours";
}

namespace {
// The rig with every grid cell split along its other diagonal.
lf::Rig other_diagonals(const lf::Rig& rig) {
  lf::Rig out = rig;
  out.triangles.clear();
  for (int r = 0; r + 1 < rig.grid.rows; ++r)
    for (int c = 0; c + 1 < rig.grid.cols; ++c) {
      auto id = [&](int rr, int cc) { return rig.cameras[rig.grid.at(rr, cc)].id; };
      // Both diagonals of the cell, each with the triangles the rig does not have.
      const std::array<std::array<int, 3>, 2> a = {
          {{id(r, c), id(r, c + 1), id(r + 1, c + 1)}, {id(r, c), id(r + 1, c + 1), id(r + 1, c)}}};
      const std::array<std::array<int, 3>, 2> b = {
          {{id(r, c), id(r, c + 1), id(r + 1, c)}, {id(r, c + 1), id(r + 1, c + 1), id(r + 1, c)}}};
      auto has = [&](const std::array<int, 3>& t) {
        for (auto u : rig.triangles) {
          std::sort(u.begin(), u.end());
          auto v = t;
          std::sort(v.begin(), v.end());
          if (u == v) return true;
        }
        return false;
      };
      for (const auto& t : has(a[0]) ? b : a) out.triangles.push_back(t);
    }
  out.finalize();
  return out;
}
}  // namespace

// Four-camera weights (lf/geometry/view.h Aperture::kFourCamera): planned
// weights sum to 1 at every pixel on and off the camera plane; an eye at a
// cell's centre blends its four cameras at 0.25 each (the tent: two at
// 0.5); for an eye on the camera plane the view is the mean of the views
// through either diagonal's tent, pixel for pixel; on a cell edge it is
// the tent's.
TEST(Plan, FourCameraWeightsAreBilinearOverTheCell) {
  const lf::Rig rig = lf::synthetic_grid_rig(5, 5, 1.0, 160, 120, 60);
  const int W = 129, H = 97;
  std::vector<cv::Mat> images;
  for (const auto& c : rig.cameras) images.push_back(lf::render_textured_plane(c, 10.0, 0.7));
  const lf::Rig flipped = other_diagonals(rig);
  for (const cv::Vec3d& eye :
       {cv::Vec3d(0.5, 0.5, 0), cv::Vec3d(-0.5, 0.5, 0), cv::Vec3d(0.0, 0.5, 0),
        cv::Vec3d(0.3, -0.6, -1.5), cv::Vec3d(0.2, 0.7, 0.8)}) {
    SCOPED_TRACE(testing::Message() << "eye " << eye);
    lf::ViewRequest req;
    req.view = lf::VirtualView::look_at(eye, {0.4, 0.4, 10}, {0, 1, 0}, 30, W, H);
    req.focal_plane = lf::FocalPlane::through({0, 0, 10}, {0, 0, 1});
    req.aperture = lf::Aperture::kFourCamera;
    const lf::ViewGeometry g(rig, req);
    std::vector<int> count;
    const std::vector<double> sum = weight_sums(rig, g, &count);
    double worst = 0;
    for (const double v : sum) worst = std::max(worst, std::abs(v - 1));
    EXPECT_LT(worst, 1e-9);
    if (eye[2] != 0) continue;
    if (eye[0] != 0) {  // a cell's centre
      int four = 0;
      for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i)
        if (g.ulr_weight(i, 1, 1) > 0) {
          ++four;
          EXPECT_NEAR(g.ulr_weight(i, 1, 1), 0.25, 1e-12);
        }
      EXPECT_EQ(four, 4);
      EXPECT_EQ(*std::min_element(count.begin(), count.end()), 4);
    }
    lf::ViewRequest tent = req;
    tent.aperture = lf::Aperture::kTent;
    cv::Mat mean;
    cv::addWeighted(lf::render_view(rig, images, tent), 0.5, lf::render_view(flipped, images, tent),
                    0.5, 0, mean);
    const cv::Mat four = lf::render_view(rig, images, req);
    // Fragments are 8-bit, premultiplied by the weight (lf/render/fragment.h):
    // four cameras at 0.25 round their colour to 4 levels, two at 0.5 to 2.
    EXPECT_LE(cv::norm(four, mean, cv::NORM_INF), 4) << "the mean of the two diagonals' tents";
    EXPECT_GT(lf::psnr(four, mean), 45);
    if (eye[0] == 0) {  // on a cell edge: the same two cameras as the tent
      EXPECT_EQ(cv::norm(four, lf::render_view(rig, images, tent), cv::NORM_INF), 0);
    }
  }
  // No scale; a rig without a grid keeps the tent's weights.
  lf::ViewRequest bad;
  bad.view = lf::VirtualView::look_at({0, 0, 0}, {0, 0, 10}, {0, 1, 0}, 30, W, H);
  bad.aperture = lf::Aperture::kFourCamera;
  bad.aperture_scale = 2;
  EXPECT_THROW(lf::validate(bad), std::invalid_argument);
  lf::Rig loose = rig;
  loose.grid = {};
  loose.triangles.clear();
  loose.finalize();
  bad.aperture_scale = 1;
  bad.view = lf::VirtualView::look_at({0.5, 0.5, 0}, {0.5, 0.5, 10}, {0, 1, 0}, 30, W, H);
  const lf::ViewGeometry g(loose, bad);
  int cams = 0;
  for (int i = 0; i < static_cast<int>(loose.cameras.size()); ++i)
    cams += g.ulr_weight(i, 1, 1) > 0;
  EXPECT_LE(cams, 3) << "no cells without a grid: the tent";
}

// A sweep over planes plans each camera once (lf/render/plan.h aim_plan):
// where plan_is_plane_free holds at both planes, the plan made at one plane
// and re-aimed at the other is exactly plan_fragment's at the other.
TEST(Plan, APlaneFreePlanReAimedIsThePlanOfTheOtherPlane) {
  lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.5, 160, 120, 45, 2.0, 11);
  int compared = 0, refused = 0;
  // Eyes on, behind and in front of the camera plane, looking at the scene
  // at different angles; tilted focal planes near and far. (Fixed values:
  // random ones drawn inside one call's arguments differ between
  // compilers.)
  const cv::Vec3d eyes[] = {{0.1, 0.2, 0.0}, {-0.6, 0.3, -1.0}, {0.7, -0.4, 0.5}, {0.0, 0.0, -2.0},
                            {0.3, 0.6, 1.2}, {-0.2, -0.7, 0.0}, {1.1, 0.1, -0.5}, {-0.9, 0.8, 0.8}};
  for (int v = 0; v < 8; ++v) {
    lf::ViewRequest req;
    const cv::Vec3d target(0.4 * (v % 3) - 0.4, 0.3 * (v % 2), 10.0 + v);
    req.view = lf::VirtualView::look_at(eyes[v], target, {0, 1, 0}, 35 + 5 * v, 90, 70);
    req.focal_plane = lf::FocalPlane::through({0, 0, 8.0 + v}, cv::Vec3d(0.05 * v - 0.2, 0.1, 1.0));
    lf::ViewRequest other = req;
    other.focal_plane =
        lf::FocalPlane::through({0, 0, 6.0 + 5 * v}, cv::Vec3d(0.1 - 0.03 * v, -0.05 * v, 1.0));
    lf::ViewRequest behind = req;  // behind the eye: every pixel's ray misses it
    behind.focal_plane = lf::FocalPlane::through({0, 0, -5}, {0, 0, 1});
    const lf::ViewGeometry a(rig, req), b(rig, other), c(rig, behind);
    for (int i = 0; i < 16; ++i) {
      EXPECT_FALSE(lf::plan_is_plane_free(c, i));
      if (!lf::plan_is_plane_free(a, i) || !lf::plan_is_plane_free(b, i)) {
        ++refused;
        continue;
      }
      lf::FragmentPlan pa = lf::plan_fragment(a, i);
      lf::aim_plan(b, pa);
      const lf::FragmentPlan pb = lf::plan_fragment(b, i);
      ASSERT_EQ(pa.runs.size(), pb.runs.size());
      for (size_t k = 0; k < pa.runs.size(); ++k) {
        EXPECT_EQ(pa.runs[k].y, pb.runs[k].y);
        EXPECT_EQ(pa.runs[k].x0, pb.runs[k].x0);
        EXPECT_EQ(pa.runs[k].x1, pb.runs[k].x1);
        EXPECT_EQ(pa.runs[k].piece, pb.runs[k].piece);
      }
      ASSERT_EQ(pa.pieces.size(), pb.pieces.size());
      for (size_t k = 0; k < pa.pieces.size(); ++k) {
        EXPECT_EQ(pa.pieces[k].H, pb.pieces[k].H);
        EXPECT_EQ(pa.pieces[k].weight_num.a, pb.pieces[k].weight_num.a);
        EXPECT_EQ(pa.pieces[k].weight_den.c, pb.pieces[k].weight_den.c);
      }
      EXPECT_EQ(pa.rect, pb.rect);
      compared += !pa.empty();
    }
  }
  std::printf("%d non-empty plans compared, %d cameras not plane-free\n", compared, refused);
  EXPECT_GT(compared, 40);
  // A surface request is never plane-free.
  lf::ViewRequest surf;
  surf.view = lf::VirtualView::look_at({0.1, 0.2, -1.0}, {0, 0, 10}, {0, 1, 0}, 40, 90, 70);
  surf.focal_plane = lf::FocalPlane::through({0, 0, 9}, {0, 0, 1});
  surf.surface.tile = 16;
  surf.surface.cols = 6, surf.surface.rows = 5;
  surf.surface.planes = {surf.focal_plane};
  surf.surface.plane_of.assign(30, 0);
  EXPECT_FALSE(lf::plan_is_plane_free(lf::ViewGeometry(rig, surf), 0));
}

// photo_consistency with the plans kept between planes gives exactly the
// costs of planning every camera again at each plane.
TEST(Plan, PhotoConsistencyWithKeptPlansIsUnchanged) {
  const lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.5, 160, 120, 45, 2.0, 11);
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  std::vector<cv::Mat> images;
  for (const auto& c : rig.cameras) images.push_back(scene.render(c, 0.0, false));
  const lf::AnalysisImages an = lf::analysis_images(rig, images, 120);
  for (int v = 0; v < 3; ++v) {
    // Eyes between the cameras, on their plane and behind it.
    const cv::Vec3d eye(0.1 * v - 0.05, 0.07 - 0.05 * v, -0.3 * v);
    lf::ViewRequest req;
    req.view = lf::VirtualView::look_at(eye, eye + cv::Vec3d(0, 0, 10), {0, 1, 0}, 40, 120, 90);
    lf::ConsistencyPlans kept;
    int kernels = 0;
    for (double q : {0.0, 0.02, 0.05, 0.1, 0.2}) {
      cv::Mat fresh, reused;
      lf::photo_consistency(an.rig, an.gray, req, q, 25.0, fresh);
      lf::photo_consistency(an.rig, an.gray, req, q, 25.0, reused, &kept);
      ASSERT_EQ(fresh.size(), reused.size());
      EXPECT_EQ(cv::norm(fresh, reused, cv::NORM_INF), 0.0) << "view " << v << " q " << q;
      // Every kernel this CPU has gives the scalar reference's costs.
      cv::Mat scalar;
      lf::photo_consistency(an.rig, an.gray, req, q, 25.0, scalar, nullptr, lf::Kernel::kScalar);
      for (lf::Kernel k : {lf::Kernel::kSse2, lf::Kernel::kAvx2, lf::Kernel::kAvx512}) {
        if (!lf::kernel_available(k)) continue;
        cv::Mat other;
        lf::photo_consistency(an.rig, an.gray, req, q, 25.0, other, nullptr, k);
        EXPECT_EQ(cv::norm(scalar, other, cv::NORM_INF), 0.0) << lf::kernel_name(k);
        ++kernels;
      }
      EXPECT_GT(cv::countNonZero(fresh >= 0), fresh.total() / 4) << "the view sees the scene";
    }
    // Grey images inside larger ones (rows with a gap between them) give the
    // same costs; an image not of its camera's size is refused.
    std::vector<cv::Mat> framed;
    for (const cv::Mat& g : an.gray) {
      cv::Mat big(g.rows + 2, g.cols + 3, CV_32F, cv::Scalar(1e6));
      g.copyTo(big(cv::Rect(1, 1, g.cols, g.rows)));
      framed.push_back(big(cv::Rect(1, 1, g.cols, g.rows)));
    }
    cv::Mat a, b;
    lf::photo_consistency(an.rig, an.gray, req, 0.05, 25.0, a);
    lf::photo_consistency(an.rig, framed, req, 0.05, 25.0, b);
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
    std::vector<cv::Mat> small = an.gray;
    small[3] = small[3](cv::Rect(0, 0, small[3].cols - 1, small[3].rows));
    EXPECT_THROW(lf::photo_consistency(an.rig, small, req, 0.05, 25.0, a), std::invalid_argument);
    int kept_plans = 0;
    for (bool r : kept.reusable) kept_plans += r;
    EXPECT_GT(kept_plans, 0);
    std::printf("view %d: %d kernel comparisons\n", v, kernels);
  }
}
