// Numerical stability on hard cases: results stay finite, weights stay valid,
// nothing crashes, and degenerate cases get their documented result.
#include <gtest/gtest.h>

#include <cmath>

#include "helpers.h"
#include "lf/focus/focus.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/parse.h"
#include "lf/quality/quality.h"
#include "lf/quality/synthetic.h"
#include "lf/render/composite.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"

namespace {

using testing_lf::check_weights;
using testing_lf::expect_valid;

const int kW = 80, kH = 60;

lf::Rig grid4(double scale = 1.0) {
  lf::Rig rig = lf::synthetic_grid_rig(4, 4, 1.0, 64, 48, 50, 1.0, 17);
  if (scale != 1.0) {
    for (lf::Camera& c : rig.cameras) c.extrinsics.t *= scale;
    rig.triangles.clear();
    rig.finalize();
  }
  return rig;
}

using testing_lf::plane_z;

lf::ViewRequest request(const cv::Vec3d& eye, const cv::Vec3d& target, double vfov,
                        const lf::FocalPlane& plane) {
  return testing_lf::look_request(eye, target, vfov, plane, kW, kH);
}

// Renders with textured images and checks the output is finite and that
// every pixel with weight is filled.
void render_ok(const lf::Rig& rig, const lf::ViewRequest& req, const std::string& what) {
  SCOPED_TRACE(what);
  std::vector<cv::Mat> images;
  for (const auto& c : rig.cameras) images.push_back(lf::render_textured_plane(c, 10.0, 0.7));
  lf::RenderStats st;
  cv::Mat out;
  ASSERT_NO_THROW(out = lf::render_view(rig, images, req, &st));
  EXPECT_EQ(out.cols, req.view.width);
  EXPECT_EQ(out.rows, req.view.height);
}

TEST(HardCases, EyeExactlyOnCameraPlane) {
  const lf::Rig rig = grid4();
  const cv::Vec3d eye(0.3, -0.2, 0.0);
  const auto req = request(eye, {0.5, 0.1, 10}, 50, plane_z(10));
  const auto c = check_weights(rig, req);
  expect_valid(c, "eye on plane");
  EXPECT_EQ(c.unseen, 0u);  // every line meets the plane at the eye
  // Defined result: weights constant over the image (the eye's barycentrics).
  const lf::ViewGeometry g(rig, req);
  const auto a = g.locate(0, 0), b = g.locate(kW - 1, kH - 1), m = g.locate(40, 30);
  EXPECT_EQ(a.simplex, b.simplex);
  EXPECT_EQ(a.simplex, m.simplex);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(a.weight[k], b.weight[k]);
  // Exactly 3 fragments, each the full frame.
  EXPECT_EQ(c.fragment_pixels, 3u * kW * kH);
  render_ok(rig, req, "eye on plane");
}

TEST(HardCases, EyeExactlyOnACamera) {
  const lf::Rig rig = grid4();
  const cv::Vec3d eye = rig.cameras[5].center();
  const auto req = request(eye, eye + cv::Vec3d(0, 0, 10), 50, plane_z(10));
  const auto c = check_weights(rig, req);
  expect_valid(c, "eye on a camera");
  EXPECT_EQ(c.unseen, 0u);
  const lf::ViewGeometry g(rig, req);
  const auto s = g.locate(10, 10);
  double w5 = 0;
  for (int k = 0; k < s.count; ++k)
    if (s.cams[k] == 5) w5 = s.weight[k];
  EXPECT_EQ(w5, 1.0);  // the camera under the eye carries the whole weight
  EXPECT_EQ(c.fragment_pixels, static_cast<size_t>(kW) * kH);
}

TEST(HardCases, EyeJustOffCameraPlane) {
  const lf::Rig rig = grid4();
  for (double dz : {1e-9, -1e-9}) {
    const cv::Vec3d eye(0.3, -0.2, dz);
    const auto req = request(eye, {0.5, 0.1, 10}, 50, plane_z(10));
    const auto c = check_weights(rig, req);
    expect_valid(c, "eye 1e-9 off the plane");
    // Continuity with the on-plane result: lines meet the plane within
    // ~1e-9 of the eye, so weights match the eye's barycentrics.
    const lf::ViewGeometry g0(rig, request({0.3, -0.2, 0}, {0.5, 0.1, 10}, 50, plane_z(10)));
    const lf::ViewGeometry g1(rig, req);
    const auto a = g0.locate(40, 30), b = g1.locate(40, 30);
    ASSERT_EQ(a.simplex, b.simplex);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(a.weight[k], b.weight[k], 1e-7);
    render_ok(rig, req, "eye 1e-9 off");
  }
}

TEST(HardCases, EyeOnFocalPlane) {
  const lf::Rig rig = grid4();
  const cv::Vec3d eye(0.2, 0.4, -1.0);
  const auto req = request(eye, {0, 0, 10}, 50, plane_z(-1.0));
  const auto c = check_weights(rig, req);
  expect_valid(c, "eye on the focal plane", false);
  // Defined result: every pixel maps to the camera pixel that sees the eye.
  const lf::ViewGeometry g(rig, req);
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const auto expect = rig.cameras[i].project(eye);
    for (auto [x, y] : {std::pair{3.0, 4.0}, {70.0, 50.0}, {40.0, 2.0}}) {
      const cv::Vec3d h = g.homography(static_cast<int>(i)) * cv::Vec3d(x, y, 1);
      ASSERT_TRUE(std::isfinite(h[0]) && std::isfinite(h[1]) && std::isfinite(h[2]));
      EXPECT_EQ(g.visible(static_cast<int>(i), x, y), expect.has_value());
      if (expect) {
        EXPECT_LT(cv::norm(cv::Vec2d(h[0] / h[2], h[1] / h[2]) - *expect), 1e-6);
      }
    }
  }
  render_ok(rig, req, "eye on focal plane");
}

TEST(HardCases, FocalPlaneParallelToViewingRays) {
  const lf::Rig rig = grid4();
  // The plane x = 0.25 contains the viewing direction of the centre pixel.
  const auto req = request({0.25, 0.1, -1}, {0.25, 0.1, 10}, 60,
                           lf::FocalPlane::through({0.25, 0, 0}, {1, 0, 0}));
  const auto c = check_weights(rig, req);
  expect_valid(c, "focal plane parallel to rays", false);
  render_ok(rig, req, "focal plane parallel to rays");
}

TEST(HardCases, FocalPlaneAtInfinity) {
  const lf::Rig rig = grid4();
  const auto req = request({0.1, 0.1, -0.5}, {0.3, 0, 10}, 50, lf::FocalPlane::infinity());
  const auto c = check_weights(rig, req);
  expect_valid(c, "plane at infinity");
  // Defined result: each camera samples the ray's direction (pure rotation).
  const lf::ViewGeometry g(rig, req);
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const lf::Camera& cam = rig.cameras[i];
    const cv::Vec3d D = g.ray(17, 23);
    const cv::Vec3d d = cam.extrinsics.R * D;
    const cv::Vec2d expect(cam.intrinsics.fx * d[0] / d[2] + cam.intrinsics.cx,
                           cam.intrinsics.fy * d[1] / d[2] + cam.intrinsics.cy);
    const cv::Vec3d h = g.homography(static_cast<int>(i)) * cv::Vec3d(17, 23, 1);
    EXPECT_LT(cv::norm(cv::Vec2d(h[0] / h[2], h[1] / h[2]) - expect), 1e-9);
  }
  // Nearly infinite planes converge to it.
  const lf::ViewGeometry far(rig, request({0.1, 0.1, -0.5}, {0.3, 0, 10}, 50, plane_z(1e12)));
  const cv::Vec3d a = g.homography(3) * cv::Vec3d(17, 23, 1);
  const cv::Vec3d b = far.homography(3) * cv::Vec3d(17, 23, 1);
  EXPECT_LT(cv::norm(cv::Vec2d(a[0] / a[2] - b[0] / b[2], a[1] / a[2] - b[1] / b[2])), 1e-6);
  render_ok(rig, req, "plane at infinity");
}

TEST(HardCases, ViewFacingAwayFromCameras) {
  const lf::Rig rig = grid4();
  // Eye behind the array looking further back: lines (not rays) still meet
  // the camera plane and the focal plane behind the eye.
  const auto req = request({0.2, 0.1, -3}, {0.2, 0.1, -13}, 40, plane_z(10));
  const auto c = check_weights(rig, req);
  expect_valid(c, "facing away");
  EXPECT_GT(c.seen, 0u);
  render_ok(rig, req, "facing away");
}

TEST(HardCases, TrianglesStraddlingTheEyePlane) {
  const lf::Rig rig = grid4();
  // Eye just in front of the array looking sideways along +x: the eye plane
  // x = 0.1 cuts through triangles of the camera surface.
  const auto req = request({0.1, 0.0, 0.5}, {10, 0.0, 0.6}, 120, plane_z(10));
  const auto c = check_weights(rig, req);
  expect_valid(c, "straddling triangles");
  EXPECT_GT(c.seen, 100u);
  EXPECT_GT(c.unseen, 0u);
  render_ok(rig, req, "straddling");
}

TEST(HardCases, LinearArray) {
  const lf::Rig rig = lf::synthetic_grid_rig(1, 6, 0.5, 64, 48, 50);
  EXPECT_EQ(rig.dimension(), 1);
  EXPECT_EQ(rig.simplices().size(), 5u);
  for (const cv::Vec3d& eye : {cv::Vec3d(0.3, 0, 0), cv::Vec3d(0.3, 0.2, -1.5)}) {
    const auto req = request(eye, {0.3, 0, 10}, 60, plane_z(10));
    const auto c = check_weights(rig, req);
    expect_valid(c, "1 x N array");
    EXPECT_GT(c.seen, 0u);
    render_ok(rig, req, "linear");
  }
  // Defined result: weights depend on s only (1D tent along the array).
  const lf::ViewGeometry g(rig, request({0.3, 0, 0}, {0.3, 0, 10}, 60, plane_z(10)));
  const auto s = g.locate(5, 5);
  ASSERT_EQ(s.count, 2);
  EXPECT_NEAR(s.weight[0] + s.weight[1], 1.0, 1e-15);
}

TEST(HardCases, CamerasMissingFromGrid) {
  const lf::Rig full = grid4();
  const lf::Rig rig = full.without({5, 0, 15});  // an interior camera and two corners
  EXPECT_EQ(rig.cameras.size(), 13u);
  // The hole left by camera 5 is triangulated: a view through it is covered.
  const cv::Vec3d eye = full.cameras[5].center();
  const auto req = request(eye, eye + cv::Vec3d(0, 0, 10), 50, plane_z(10));
  const auto c = check_weights(rig, req);
  expect_valid(c, "missing cameras");
  EXPECT_EQ(c.unseen, 0u);
  const auto c2 = check_weights(rig, request({0, 0, -2}, {0, 0, 10}, 70, plane_z(10)));
  expect_valid(c2, "missing cameras, eye behind");
  render_ok(rig, req, "missing cameras");
}

TEST(HardCases, ExtremeFieldsOfView) {
  const lf::Rig rig = grid4();
  for (double fov : {1.0, 170.0}) {
    for (double z : {0.0, -1.0}) {
      const auto req = request({0.2, 0.3, z}, {0.4, 0.2, 10}, fov, plane_z(10));
      const auto c = check_weights(rig, req);
      expect_valid(c, "fov " + std::to_string(fov));
      render_ok(rig, req, "fov");
    }
  }
}

TEST(HardCases, SceneScales) {
  // The same scene at scale 1e-6, 1 and 1e6 gives the same weights and maps
  // pixels to the same camera pixels.
  const lf::Rig ref = grid4();
  const auto base = request({0.3, -0.2, -1.0}, {0.5, 0.1, 10}, 50, plane_z(10));
  const lf::ViewGeometry g0(ref, base);
  for (double s : {1e-6, 1e6}) {
    const lf::Rig rig = grid4(s);
    auto req = base;
    req.view.position *= s;
    req.focal_plane = plane_z(10 * s);
    const auto c = check_weights(rig, req);
    expect_valid(c, "scale " + std::to_string(s));
    const lf::ViewGeometry g(rig, req);
    for (auto [x, y] : {std::pair{5.0, 7.0}, {60.0, 33.0}, {79.0, 59.0}}) {
      const auto a = g0.locate(x, y), b = g.locate(x, y);
      ASSERT_EQ(a.simplex, b.simplex);
      for (int k = 0; k < a.count; ++k) EXPECT_NEAR(a.weight[k], b.weight[k], 1e-9);
      for (int i : {0, 6, 15}) {
        const cv::Vec3d h0 = g0.homography(i) * cv::Vec3d(x, y, 1);
        const cv::Vec3d h1 = g.homography(i) * cv::Vec3d(x, y, 1);
        EXPECT_NEAR(h0[0] / h0[2], h1[0] / h1[2], 1e-6);
        EXPECT_NEAR(h0[1] / h0[2], h1[1] / h1[2], 1e-6);
      }
    }
    render_ok(rig, req, "scale");
  }
}

TEST(HardCases, InvalidRequestsAreRejected) {
  const lf::Rig rig = grid4();
  auto req = request({0, 0, -1}, {0, 0, 10}, 50, plane_z(10));
  auto bad = req;
  bad.view.vfov_deg = 0;
  EXPECT_THROW(lf::ViewGeometry(rig, bad), std::invalid_argument);
  bad = req;
  bad.view.position[0] = NAN;
  EXPECT_THROW(lf::ViewGeometry(rig, bad), std::invalid_argument);
  bad = req;
  bad.focal_plane = {{0, 0, 0}, 0};
  EXPECT_THROW(lf::ViewGeometry(rig, bad), std::invalid_argument);
  bad = req;
  bad.view.R = bad.view.R * 2.0;
  EXPECT_THROW(lf::ViewGeometry(rig, bad), std::invalid_argument);
  bad = req;
  bad.view.width = 0;
  EXPECT_THROW(lf::ViewGeometry(rig, bad), std::invalid_argument);
}

}  // namespace

// An eye exactly on the hull's border, on the camera plane: the in-between
// camera of a sparser grid's border edge, on a rig whose cameras are
// exactly coplanar (synthetic data, HCI, Blender). The tie rule perturbs a
// point on a facet outwards there, so no triangle claimed it and the view
// was black; it now takes the border edge's two cameras, and reproduces the
// held-out camera as the other in-between views do. The same at a corner.
TEST(HardCases, EyeExactlyOnTheHullsBorder) {
  const lf::Rig full = lf::synthetic_grid_rig(5, 5, 1.0, kW, kH, 50);
  std::vector<int> odd;
  for (int r = 0; r < 5; ++r)
    for (int c = 0; c < 5; ++c)
      if (r % 2 || c % 2) odd.push_back(full.grid.at(r, c));
  const lf::Rig rig = full.without(odd);
  for (const auto& [r, c] : {std::pair{1, 4}, std::pair{4, 3}, std::pair{0, 0}, std::pair{2, 1}}) {
    SCOPED_TRACE(testing::Message() << "the eye at grid (" << r << ", " << c << ")");
    const cv::Vec3d eye = full.cameras[full.grid.at(r, c)].center();
    const auto req = request(eye, eye + cv::Vec3d(0, 0, 10), 50, plane_z(10));
    ASSERT_TRUE(lf::ViewGeometry(rig, req).eye_on_camera_plane());
    const auto w = check_weights(rig, req);
    expect_valid(w, "on the border");
    EXPECT_EQ(w.unseen, 0u);
    EXPECT_GE(w.fragment_pixels, static_cast<size_t>(kW) * kH);
    EXPECT_LE(w.fragment_pixels, 3u * kW * kH);
    std::vector<cv::Mat> images;
    for (const auto& cam : rig.cameras) images.push_back(lf::render_textured_plane(cam, 10.0, 0.7));
    const cv::Mat truth = lf::render_textured_plane(full.cameras[full.grid.at(r, c)], 10.0, 0.7);
    const cv::Mat out = lf::render_view(rig, images, req);
    EXPECT_GT(
        lf::psnr(out, lf::camera_view_image(full.cameras[full.grid.at(r, c)], truth, kW, kH), 2),
        30);
  }
}
