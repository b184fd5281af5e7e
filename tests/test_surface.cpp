// The focal surface estimated from the images (lf/focal_surface.h): one
// plane where the scene is flat, more where it has depth; graceful on hard
// cases; better pictures than one plane on synthetic and real light fields.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "helpers.h"
#include "lf/datasets.h"
#include "lf/focal_surface.h"
#include "lf/focus.h"
#include "lf/quality.h"
#include "lf/render_view.h"
#include "lf/rig_ops.h"
#include "lf/synthetic.h"

namespace {

using testing_lf::data_path;
using testing_lf::Held;
using testing_lf::hold_out;
using testing_lf::psnr_at;

double psnr_with(const Held& h, const lf::SurfaceEstimate& e) {
  lf::ViewRequest r = h.req;
  lf::apply(e, r);
  return lf::psnr(lf::render_view(h.rig, h.images, r), h.truth, r.view.height / 40);
}

// 5x5 synthetic grid, 320x240 images; its centre camera is index 12.
lf::Rig small_rig() {
  return lf::synthetic_grid_rig(5, 5, 0.1, 320, 240, 40);
}
// The texture's wavelength grows with depth, so that it looks alike at any.
std::vector<cv::Mat> plane_images(const lf::Rig& rig, double depth) {
  std::vector<cv::Mat> out;
  for (const auto& c : rig.cameras)
    out.push_back(lf::render_textured_plane(c, depth, 0.05 * depth / 3.0));
  return out;
}

// The synthetic scene (a disc before a background) at time t, camera 12 held out.
Held disc_scene(double t) {
  const lf::Rig rig = small_rig();
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  std::vector<cv::Mat> images;
  for (const auto& c : rig.cameras) images.push_back(scene.render(c, t, false));
  return hold_out(rig, images, 12, 320, 240);
}

TEST(Surface, AFlatSceneNeedsOnePlane) {
  const lf::Rig rig = small_rig();
  const Held h = hold_out(rig, plane_images(rig, 3.0), 12, 320, 240);
  const lf::FocalSurfaceEstimator est(h.rig, h.images);
  const lf::SurfaceEstimate e = est.estimate(h.req);
  const double step = est.candidate_q(1);
  std::printf("flat: q %.4f (truth %.4f, step %.4f), planes %d\n", e.single_q, 1 / 3.0, step,
              e.planes_used);
  EXPECT_TRUE(e.surface.empty()) << e.planes_used << " planes for a flat scene";
  EXPECT_EQ(e.planes_used, 1);
  EXPECT_NEAR(e.single_q, 1 / 3.0, step / 2);
  EXPECT_EQ(e.planes_evaluated, est.options().planes + est.options().fine_planes);
}

TEST(Surface, TwoDepthsGetTheirOwnPlanesAndASharperPicture) {
  // A textured disc in front of a textured background (occlusion edges).
  const lf::Rig rig = small_rig();
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  const Held h = disc_scene(0.3);
  const lf::FocalSurfaceEstimator est(h.rig, h.images);
  const lf::SurfaceEstimate e = est.estimate(h.req);
  const double step = est.candidate_q(1);
  // Tiles wholly on the disc or wholly on the background: their depth.
  const lf::Camera& cam = rig.cameras[12];
  const cv::Vec3d centre = scene.disc_centre(0.3);
  int near_ok = 0, near_n = 0, far_ok = 0, far_n = 0;
  const int T = e.surface.tile;
  ASSERT_FALSE(e.surface.empty());
  for (int r = 0; r < e.surface.rows; ++r)
    for (int c = 0; c < e.surface.cols; ++c) {
      int on_disc = 0, n = 0;
      for (int y = r * T; y < std::min(240, (r + 1) * T); y += 3)
        for (int x = c * T; x < std::min(320, (c + 1) * T); x += 3, ++n) {
          // The camera's ray through (x, y) meets the disc's plane where?
          const cv::Vec3d d =
              cam.extrinsics.R.t() * cv::Vec3d((x - cam.intrinsics.cx) / cam.intrinsics.fx,
                                               (y - cam.intrinsics.cy) / cam.intrinsics.fy, 1.0);
          const cv::Vec3d p = cam.center() + d * ((scene.near_depth - cam.center()[2]) / d[2]);
          on_disc += cv::norm(p - centre) < scene.disc_radius;
        }
      const int t = r * e.surface.cols + c;
      if (!e.textured[t]) continue;
      if (on_disc == n) ++near_n, near_ok += std::abs(e.tile_q[t] - 1 / scene.near_depth) <= step;
      if (on_disc == 0) ++far_n, far_ok += std::abs(e.tile_q[t] - 1 / scene.far_depth) <= step;
    }
  lf::ViewRequest q = h.req;
  const double p_auto = psnr_at(h, lf::AutofocusContext(h.rig, h.images).run(q).plane);
  const double p_surface = psnr_with(h, e);
  std::printf(
      "disc: %d planes; disc tiles %d/%d within a step, background %d/%d; PSNR auto %.2f dB, "
      "surface %.2f dB\n",
      e.planes_used, near_ok, near_n, far_ok, far_n, p_auto, p_surface);
  EXPECT_GE(e.planes_used, 2);
  EXPECT_LE(e.planes_used, 8) << "two depths need few planes";
  ASSERT_GT(near_n, 10);
  ASSERT_GT(far_n, 50);
  EXPECT_GE(near_ok, 0.9 * near_n);
  EXPECT_GE(far_ok, 0.9 * far_n);
  EXPECT_GT(p_surface, p_auto + 3.0);  // measured +4.6 dB
}

TEST(Surface, HardCasesAreFiniteAndFallBack) {
  const lf::Rig rig = small_rig();
  // Textureless: every camera sees one grey.
  {
    std::vector<cv::Mat> grey(rig.cameras.size(), cv::Mat(240, 320, CV_8UC4, cv::Scalar::all(128)));
    const Held h = hold_out(rig, grey, 12, 320, 240);
    const lf::SurfaceEstimate e = lf::FocalSurfaceEstimator(h.rig, h.images).estimate(h.req);
    EXPECT_TRUE(std::isfinite(e.single_q));
    EXPECT_TRUE(e.surface.empty());
    for (bool t : e.textured) EXPECT_FALSE(t);
  }
  // A scene at infinity: the plane at (near) zero inverse depth.
  {
    const Held h = hold_out(rig, plane_images(rig, 1e6), 12, 320, 240);
    const lf::FocalSurfaceEstimator est(h.rig, h.images);
    const lf::SurfaceEstimate e = est.estimate(h.req);
    EXPECT_LE(e.single_q, est.candidate_q(1) / 2);
    EXPECT_TRUE(e.surface.empty()) << e.planes_used;
  }
  // Noisy images of a flat scene (sigma 12 levels): still few planes, and
  // the picture is no worse than the single plane's.
  {
    std::vector<cv::Mat> noisy = plane_images(rig, 3.0);
    cv::RNG rng(3);
    for (auto& m : noisy) {
      cv::Mat n(m.size(), CV_16SC4);
      rng.fill(n, cv::RNG::NORMAL, 0, 12);
      cv::Mat s;
      m.convertTo(s, CV_16SC4);
      s += n;
      s.convertTo(m, CV_8UC4);
    }
    const Held h = hold_out(rig, noisy, 12, 320, 240);
    const lf::FocalSurfaceEstimator est(h.rig, h.images);
    const lf::SurfaceEstimate e = est.estimate(h.req);
    const double ps = psnr_with(h, e), p1 = psnr_at(h, e.single);
    std::printf("noisy flat: %d planes, q %.4f (truth %.4f); PSNR surface %.2f, single %.2f\n",
                e.planes_used, e.single_q, 1 / 3.0, ps, p1);
    EXPECT_NEAR(e.single_q, 1 / 3.0, est.candidate_q(1));
    EXPECT_LE(e.planes_used, 3);
    EXPECT_GT(ps, p1 - 0.2);
  }
  // A view that sees no camera surface at all (looking away): finite.
  {
    const Held h = hold_out(rig, plane_images(rig, 3.0), 12, 64, 48);
    lf::ViewRequest away = h.req;
    away.view = lf::VirtualView::look_at({0, 0, 0}, {0, 0, -1}, {0, 1, 0}, 40, 64, 48);
    const lf::SurfaceEstimate e = lf::FocalSurfaceEstimator(h.rig, h.images).estimate(away);
    EXPECT_TRUE(std::isfinite(e.single_q));
    EXPECT_TRUE(e.surface.empty());
  }
}

TEST(Surface, ASteadyViewAmortisesTheSweep) {
  // With stride 4, each frame sweeps a quarter of the planes and reuses the
  // rest: the first frame sweeps all, and a steady view's surface is the one
  // estimated from scratch.
  const lf::Rig rig = small_rig();
  const Held h = disc_scene(0.0);
  lf::SurfaceOptions opt;
  opt.stride = 4;
  const lf::FocalSurfaceEstimator est(h.rig, h.images, opt);
  const lf::SurfaceEstimate scratch = est.estimate(h.req);
  lf::SurfaceCosts carry;
  for (int frame = 0; frame < 6; ++frame) {
    const lf::SurfaceEstimate e = est.estimate(h.req, &carry);
    EXPECT_EQ(e.planes_evaluated,
              frame == 0 ? opt.planes + opt.fine_planes : (opt.planes + opt.fine_planes) / 4)
        << frame;
    EXPECT_EQ(e.surface.plane_of, scratch.surface.plane_of) << frame;
    EXPECT_EQ(e.tile_q, scratch.tile_q) << frame;
  }
  // Another view size starts afresh.
  lf::ViewRequest small = h.req;
  small.view = lf::VirtualView::from_camera(rig.cameras[12], 160, 120);
  EXPECT_EQ(est.estimate(small, &carry).planes_evaluated, opt.planes + opt.fine_planes);
}

TEST(Surface, BadOptionsAreRefused) {
  const lf::Rig rig = small_rig();
  const auto images = plane_images(rig, 3.0);
  auto refused = [&](auto mutate) {
    lf::SurfaceOptions o;
    mutate(o);
    EXPECT_THROW(lf::FocalSurfaceEstimator(rig, images, o), std::invalid_argument);
  };
  refused([](lf::SurfaceOptions& o) { o.tile = 2; });
  refused([](lf::SurfaceOptions& o) { o.planes = 2; });
  refused([](lf::SurfaceOptions& o) { o.planes = lf::FocalSurface::kMaxPlanes; });
  refused([](lf::SurfaceOptions& o) { o.stride = 0; });
  refused([](lf::SurfaceOptions& o) { o.max_parallax_px = 0; });
  EXPECT_THROW(lf::FocalSurfaceEstimator(rig, {images[0]}), std::invalid_argument);
}

TEST(Surface, DisparityErrorsAgainstAGroundTruthMap) {
  lf::Rig rig = small_rig();
  rig.has_focal_param = true;  // a = 0.5 - 100 q; d = -0.1 a
  rig.focal_param_infinity = 0.5;
  rig.focal_param_f_px = 100;
  // 40x24 pixels in 16-pixel tiles: 3 x 2, the last column and row clipped.
  lf::SurfaceEstimate e;
  e.tile_q = {0, 0.001, 0.002, 0.003, 0.004, 0.005};
  e.textured = {true, true, false, true, true, true};
  cv::Mat gt(24, 40, CV_32F);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 40; ++x) {
      const int t = (y / 16) * 3 + x / 16;
      gt.at<float>(y, x) = static_cast<float>(-0.1 * (0.5 - 100 * e.tile_q[t]) + 0.01 * t);
    }
  gt.at<float>(3, 3) = 100.0f;  // one outlier: the tile's median ignores it
  const std::vector<double> err = lf::tile_disparity_errors(rig, e, e.tile_q, gt, 16, 0.1);
  ASSERT_EQ(err.size(), 5u);  // tile 2 is not textured
  const double expected[] = {0.0, 0.01, 0.03, 0.04, 0.05};
  for (size_t k = 0; k < err.size(); ++k) EXPECT_NEAR(err[k], expected[k], 1e-6) << k;
  EXPECT_THROW(lf::tile_disparity_errors(rig, e, {0, 0}, gt, 16, 0.1), std::invalid_argument);
  EXPECT_THROW(lf::tile_disparity_errors(rig, e, e.tile_q, gt, 8, 0.1), std::invalid_argument);
  cv::Mat gt8;
  gt.convertTo(gt8, CV_8U);
  EXPECT_THROW(lf::tile_disparity_errors(rig, e, e.tile_q, gt8, 16, 0.1), std::invalid_argument);
  rig.has_focal_param = false;
  EXPECT_THROW(lf::tile_disparity_errors(rig, e, e.tile_q, gt, 16, 0.1), std::invalid_argument);
}

TEST(Surface, StanfordChessLeaveOneOutBeatsAutoFocus) {
  LF_NEEDS_DATA("stanford-chess");
  // As RealData.StanfordChessLeaveOneOut: 8x8 block, half-resolution images,
  // 320x240 output, four interior cameras held out in turn.
  const lf::Rig rig = lf::scale_rig(
      lf::grid_block(lf::import_dataset(data_path("stanford-chess")), 0, 0, 8, 8), 0.5);
  const auto images = lf::load_images(rig);
  double gain = 0;
  for (auto [r, c] : {std::pair{2, 3}, {3, 5}, {5, 2}, {4, 4}}) {
    const Held h = hold_out(rig, images, rig.grid.at(r, c), 320, 240);
    lf::ViewRequest q = h.req;
    const double p_auto = psnr_at(h, lf::AutofocusContext(h.rig, h.images).run(q).plane);
    const lf::SurfaceEstimate e = lf::FocalSurfaceEstimator(h.rig, h.images).estimate(h.req);
    const double p = psnr_with(h, e);
    std::printf("chess r%dc%d: auto %.2f dB, surface %.2f dB (%d planes)\n", r, c, p_auto, p,
                e.planes_used);
    gain += (p - p_auto) / 4;
    EXPECT_GT(p, p_auto + 3.5);  // measured +4.8 .. +5.1 dB
  }
  EXPECT_GT(gain, 4.0);
}

TEST(Surface, HciCottonMatchesTheGroundTruthAndBeatsTheBestPlane) {
  LF_NEEDS_DATA("hci-cotton");
  const lf::Rig rig = lf::import_dataset(data_path("hci-cotton"));
  const auto images = lf::load_images(rig);
  cv::Mat disp = lf::read_pfm(data_path("hci-cotton/gt_disp_lowres.pfm"));  // centre view
  ASSERT_EQ(disp.size(), cv::Size(512, 512));
  const Held h = hold_out(rig, images, 40, 512, 512);
  const lf::FocalSurfaceEstimator est(h.rig, h.images);
  const lf::SurfaceEstimate e = est.estimate(h.req);
  ASSERT_FALSE(e.surface.empty());
  // HCI disparity d (px per view step) <-> light-slab parameter a = -d / baseline.
  auto disparity = [&](double q) { return -0.025 * lf::focal_param_from_inverse_depth(h.rig, q); };
  const double step_px = disparity(est.candidate_q(1)) - disparity(0);
  const std::vector<double> err =
      lf::tile_disparity_errors(h.rig, e, e.tile_q, disp, est.options().tile, 0.025);
  const double med = err[err.size() / 2], p90 = err[err.size() * 9 / 10];
  // The estimate's single plane over the same tiles: what one plane misses.
  const std::vector<double> flat = lf::tile_disparity_errors(
      h.rig, e, std::vector<double>(e.tile_q.size(), e.single_q), disp, est.options().tile, 0.025);
  const double flat_med = flat[flat.size() / 2];
  // Best single plane: a sweep against the held-out image (an oracle).
  double best = 0;
  for (int k = 0; k <= 60; ++k)
    best = std::max(best,
                    psnr_at(h, lf::plane_from_focal_param(h.rig, (-1.5 + 3.0 * k / 60) / -0.025)));
  const double p = psnr_with(h, e);
  std::printf(
      "cotton: %zu textured tiles, |disparity error| median %.3f px, 90%% %.3f px (plane step "
      "%.3f px; its single plane: median %.3f px); %d planes; PSNR surface %.2f dB, best single "
      "plane %.2f dB\n",
      err.size(), med, p90, std::abs(step_px), flat_med, e.planes_used, p, best);
  // Measured: 774 textured tiles, median 0.10 px, 90th percentile 1.05 px
  // (tiles across depth edges and on faint texture); the single plane's
  // median 0.33 px; +1.96 dB.
  EXPECT_GT(err.size(), 600u);
  EXPECT_EQ(flat.size(), err.size());
  EXPECT_LT(med, 0.5 * flat_med);
  EXPECT_LT(med, 0.2);
  EXPECT_LT(p90, 1.5);
  EXPECT_GT(p, best + 1.5);
}

}  // namespace
