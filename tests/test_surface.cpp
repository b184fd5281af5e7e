// The focal surface estimated from the images (lf/focus/focal_surface.h): one
// plane where the scene is flat, more where it has depth; graceful on hard
// cases; better pictures than one plane on synthetic and real light fields.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <opencv2/core/utility.hpp>
#include <random>

#include "helpers.h"
#include "lf/focus/focal_surface.h"
#include "lf/focus/focus.h"
#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/geometry/rig_ops.h"
#include "lf/io/datasets.h"
#include "lf/quality/quality.h"
#include "lf/quality/sweep.h"
#include "lf/quality/synthetic.h"
#include "lf/render/composite.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"

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

// The tiles of `e` (for disc_scene(t)'s 320x240 view from camera 12) that
// lie wholly on the disc or wholly on the background, and how many of them
// are within `step` of their true inverse depth.
struct DiscTiles {
  int near_ok = 0, near_n = 0, far_ok = 0, far_n = 0;
};
DiscTiles disc_tiles(const lf::SurfaceEstimate& e, double step, double t) {
  const lf::Rig rig = small_rig();
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  const lf::Camera& cam = rig.cameras[12];
  const cv::Vec3d centre = scene.disc_centre(t);
  DiscTiles d;
  const int T = e.surface.tile;
  for (int r = 0; r < e.surface.rows; ++r)
    for (int c = 0; c < e.surface.cols; ++c) {
      int on_disc = 0, n = 0;
      for (int y = r * T; y < std::min(240, (r + 1) * T); y += 3)
        for (int x = c * T; x < std::min(320, (c + 1) * T); x += 3, ++n) {
          // The camera's ray through (x, y) meets the disc's plane where?
          const cv::Vec3d dir =
              cam.extrinsics.R.t() * cv::Vec3d((x - cam.intrinsics.cx) / cam.intrinsics.fx,
                                               (y - cam.intrinsics.cy) / cam.intrinsics.fy, 1.0);
          const cv::Vec3d p = cam.center() + dir * ((scene.near_depth - cam.center()[2]) / dir[2]);
          on_disc += cv::norm(p - centre) < scene.disc_radius;
        }
      const int k = r * e.surface.cols + c;
      if (!e.textured[k]) continue;
      if (on_disc == n)
        ++d.near_n, d.near_ok += std::abs(e.tile_q[k] - 1 / scene.near_depth) <= step;
      if (on_disc == 0) ++d.far_n, d.far_ok += std::abs(e.tile_q[k] - 1 / scene.far_depth) <= step;
    }
  return d;
}

// Two depths need few planes; of the tiles wholly on the disc, at least
// `near_share`, and of those wholly on the background 90 %, within a step.
void expect_two_depths(const lf::SurfaceEstimate& e, const DiscTiles& d, double near_share) {
  EXPECT_GE(e.planes_used, 2);
  EXPECT_LE(e.planes_used, 8) << "two depths need few planes";
  ASSERT_GT(d.near_n, 10);
  ASSERT_GT(d.far_n, 50);
  EXPECT_GE(d.near_ok, near_share * d.near_n);
  EXPECT_GE(d.far_ok, 0.9 * d.far_n);
}

// Planes that one estimate from scratch sweeps: pass 1's, per tile and
// (with second planes) per cell, and pass 2's.
int swept(const lf::SurfaceOptions& opt) {
  return opt.planes * (opt.second_planes ? 2 : 1) + opt.fine_planes;
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
  EXPECT_EQ(e.planes_evaluated, swept(est.options()));
}

TEST(Surface, TwoDepthsGetTheirOwnPlanesAndASharperPicture) {
  // A textured disc in front of a textured background (occlusion edges).
  const Held h = disc_scene(0.3);
  const lf::FocalSurfaceEstimator est(h.rig, h.images);
  const lf::SurfaceEstimate e = est.estimate(h.req);
  const double step = est.candidate_q(1);
  ASSERT_FALSE(e.surface.empty());
  const DiscTiles d = disc_tiles(e, step, 0.3);
  lf::ViewRequest q = h.req;
  const double p_auto = psnr_at(h, lf::AutofocusContext(h.rig, h.images).run(q).plane);
  const double p_surface = psnr_with(h, e);
  std::printf(
      "disc: %d planes; disc tiles %d/%d within a step, background %d/%d; PSNR auto %.2f dB, "
      "surface %.2f dB\n",
      e.planes_used, d.near_ok, d.near_n, d.far_ok, d.far_n, p_auto, p_surface);
  expect_two_depths(e, d, 0.9);
  EXPECT_GT(p_surface, p_auto + 3.0);  // measured +4.6 dB
}

// The synthetic scene at t = 0.3 (bars of `bar_px` camera pixels about
// every `pitch_px` when bar_px > 0, else the disc) seen by every camera of
// small_rig(), and a 320x240 view from behind the camera plane between
// cameras (three cameras blend at every pixel) with its analytic image.
struct OffPlaneView {
  lf::Rig rig = small_rig();
  lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  std::vector<cv::Mat> images;
  lf::ViewRequest req;
  cv::Mat truth;
  explicit OffPlaneView(double bar_px = 0, double pitch_px = 0,
                        cv::Vec3d offset = cv::Vec3d(0.037, 0.021, -0.3), double t = 0.3) {
    const double px = scene.near_depth / rig.cameras[12].intrinsics.fy;  // rig units per pixel
    scene.bar_width = bar_px * px;
    scene.bar_pitch = pitch_px * px;
    for (const auto& c : rig.cameras) images.push_back(scene.render(c, t, false));
    req.view = lf::VirtualView::from_camera(rig.cameras[12], 320, 240);
    req.view.position = rig.cameras[12].center() + offset;
    lf::Camera eye = rig.cameras[12];
    eye.intrinsics = req.view.intrinsics();
    eye.extrinsics.t = -(req.view.R * req.view.position);
    truth = scene.render(eye, t, false);
  }
  double psnr(const lf::ViewRequest& r, lf::RenderStats* st = nullptr) const {
    return lf::psnr(lf::render_view(rig, images, r, st), truth, 6);
  }
};

TEST(Surface, SecondPlanesAtDepthEdgesSharpenTheDiscsRim) {
  // Tiles on the disc's rim hold both depths: one plane per tile doubles
  // one of them there; a second plane, chosen per pixel, does not.
  const OffPlaneView v;
  lf::SurfaceOptions opt;
  opt.second_planes = true;
  const lf::SurfaceEstimate e = lf::FocalSurfaceEstimator(v.rig, v.images, opt).estimate(v.req);
  lf::ViewRequest one = v.req, two = v.req;
  lf::apply(e, two);
  lf::apply(e, one);
  one.surface.second_of.clear();
  lf::RenderStats s1, s2;
  const double p1 = v.psnr(one, &s1), p2 = v.psnr(two, &s2);
  const int tiles = e.surface.cols * e.surface.rows;
  std::printf(
      "disc rim: %d of %d tiles with a second plane; PSNR one plane per tile %.2f dB, two %.2f "
      "dB; fragment pixels %.2fx -> %.2fx the output\n",
      e.two_plane_tiles, tiles, p1, p2, s1.fragment_pixels / (320.0 * 240),
      s2.fragment_pixels / (320.0 * 240));
  // Measured: 59 of 300 tiles, 37.89 -> 41.32 dB, 3.00x -> 3.70x.
  EXPECT_GT(e.two_plane_tiles, 10);
  EXPECT_LT(e.two_plane_tiles, tiles / 4) << "only the rim needs two planes";
  EXPECT_EQ(e.two_plane_tiles, e.surface.two_plane_tiles());
  EXPECT_GT(p2, p1 + 2.5);
  EXPECT_LT(s2.fragment_pixels, 1.3 * s1.fragment_pixels);
  // A flat scene still needs one plane and no second.
  const Held h = hold_out(v.rig, plane_images(v.rig, 3.0), 12, 320, 240);
  const lf::SurfaceEstimate flat = lf::FocalSurfaceEstimator(h.rig, h.images, opt).estimate(h.req);
  EXPECT_TRUE(flat.surface.empty());
  EXPECT_EQ(flat.two_plane_tiles, 0);
}

TEST(Surface, ThinBarsArePickedPerPixelFromTwoPlanes) {
  // Bars 6 pixels wide, about 20 apart, before a background: every tile of
  // the grating holds both depths. With the two true planes in every tile,
  // the compositor's per-pixel choice (the nearer layer unless the other's
  // cameras agree clearly better) recovers the bars.
  const OffPlaneView v(6, 20);
  lf::FocalSurface fs;
  fs.tile = 16, fs.cols = 20, fs.rows = 15;
  fs.planes = {lf::plane_at_depth(v.rig, v.scene.far_depth),
               lf::plane_at_depth(v.rig, v.scene.near_depth)};
  fs.plane_of.assign(300, 0);
  lf::ViewRequest far = v.req, both = v.req, near_first = v.req;
  far.focal_plane = both.focal_plane = near_first.focal_plane = fs.planes[0];
  both.surface = fs;
  both.surface.second_of.assign(300, 1);
  near_first.surface = fs;
  near_first.surface.plane_of.assign(300, 1);
  near_first.surface.second_of.assign(300, 0);
  const double p_far = v.psnr(far), p_both = v.psnr(both), p_swapped = v.psnr(near_first);
  std::printf("thin bars: far plane %.2f dB, both planes per pixel %.2f dB (layers swapped %.2f)\n",
              p_far, p_both, p_swapped);
  EXPECT_GT(p_both, p_far + 5.0);  // measured +9.9 dB (+8.5 with a 3 x 3 choice)
  // The choice depends on depth, not on which layer a plane is sent in.
  EXPECT_NEAR(p_swapped, p_both, 0.05);
  EXPECT_EQ(p_swapped, p_both);
  // Layer 0 alone is Compositor's frame, bit for bit; a layer other than 0
  // and 1 is refused.
  const lf::ViewGeometry g(v.rig, both);
  std::vector<lf::Fragment> frags(v.rig.cameras.size() + 1);
  std::vector<lf::FragmentPixels> px;
  for (int i = 0; i < static_cast<int>(v.rig.cameras.size()); ++i) {
    lf::render_fragment(lf::plan_fragment(g, i, 0), v.rig.cameras[i], v.images[i], frags[i]);
    px.push_back({&frags[i], frags[i].pixels.data()});
  }
  lf::Compositor plain;
  lf::LayerCompositor lc;
  cv::Mat a, b, choice;
  plain.composite(320, 240, px, b);
  frags.back() = frags[0];
  frags.back().layer = 2;
  px.push_back({&frags.back(), frags.back().pixels.data()});
  const auto refused = lc.composite(320, 240, px, a, &choice);
  ASSERT_EQ(refused.size(), 1u);
  EXPECT_EQ(refused[0].first, px.size() - 1);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  EXPECT_EQ(cv::countNonZero(choice), 0);
  // With layer 1 too: variances where it has weight, finite; the choice
  // takes layer 1 somewhere and not everywhere.
  for (int i = 0; i < static_cast<int>(v.rig.cameras.size()); ++i) {
    lf::Fragment f;
    lf::render_fragment(lf::plan_fragment(g, i, 1), v.rig.cameras[i], v.images[i], f);
    frags.push_back(f);
  }
  px.clear();
  for (const lf::Fragment& f : frags)
    if (f.layer < 2) px.push_back({&f, f.pixels.data()});
  EXPECT_TRUE(lc.composite(320, 240, px, a, &choice).empty());
  EXPECT_TRUE(cv::checkRange(lc.variance(0)) && cv::checkRange(lc.variance(1)));
  // The variances against sums of squares taken here, one pixel at a time
  // (the compositor's formula and order, in float): bit for bit wherever
  // layer 1 has weight (the compositor adds four pixels at a time).
  {
    std::vector<lf::FragmentPixels> only[2];
    for (const lf::FragmentPixels& p : px) only[p.fragment->layer].push_back(p);
    lf::Compositor sums[2];
    cv::Mat unused;
    for (int l = 0; l < 2; ++l) {
      sums[l].set_keep_sums(true);  // read below
      sums[l].composite(320, 240, only[l], unused);
    }
    int compared = 0;
    for (int l = 0; l < 2; ++l) {
      cv::Mat sq(240, 320, CV_32FC1, cv::Scalar(0));
      for (const lf::FragmentPixels& fp : only[l]) {
        const lf::Fragment& f = *fp.fragment;
        const uint8_t* q = fp.pixels;
        for (int r = 0; r < f.rect.height; ++r)
          for (int x = f.spans[r][0]; x < f.spans[r][1]; ++x, q += 4) {
            if (q[3] == 0) continue;
            const float p0 = q[0], p1 = q[1], p2 = q[2];
            sq.at<float>(f.rect.y + r, x) += 255.0f * (p0 * p0 + p1 * p1 + p2 * p2) / q[3];
          }
      }
      const cv::Mat v = lc.variance(l);
      int differ = 0;
      for (int y = 0; y < 240; ++y)
        for (int x = 0; x < 320; ++x) {
          if (sums[1].weight_at(x, y) == 0) continue;
          const uint32_t* s = sums[l].sums_at(x, y);
          float want = 0;
          if (s[3] > 0) {
            const float W = s[3] / 255.0f;
            const float m0 = s[0] / W, m1 = s[1] / W, m2 = s[2] / W;
            want = std::max(0.0f, sq.at<float>(y, x) / W - (m0 * m0 + m1 * m1 + m2 * m2));
          }
          differ += v.at<float>(y, x) != want;
          ++compared;
        }
      EXPECT_EQ(differ, 0) << "layer " << l;
    }
    EXPECT_GT(compared, 2000);
  }
  // Layer 0 drawn band by band into the sums and squares instead (the CPU
  // renderer's way, no layer-0 fragment in memory): the same frame, choice
  // and variances, bit for bit; a drawing of layer 1 is refused there.
  {
    std::vector<lf::FragmentPixels> ones;
    for (const lf::FragmentPixels& p : px)
      if (p.fragment->layer == 1) ones.push_back(p);
    const size_t n = v.rig.cameras.size();
    std::vector<lf::FragmentPlan> plans;
    for (size_t i = 0; i < n; ++i) plans.push_back(lf::plan_fragment(g, static_cast<int>(i), 0));
    plans.push_back(lf::plan_fragment(g, 0, 1));
    std::vector<lf::FragmentDrawing> draws;
    for (size_t i = 0; i <= n; ++i)
      draws.push_back({&plans[i], &v.rig.cameras[i % n], &v.images[i % n]});
    lf::LayerCompositor fused;
    cv::Mat fa, fchoice;
    const auto left = fused.composite(320, 240, ones, draws, fa, &fchoice);
    ASSERT_EQ(left.size(), 1u);
    EXPECT_EQ(left[0].first, ones.size() + n);  // the layer-1 drawing
    EXPECT_EQ(cv::norm(fa, a, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(fchoice, choice, cv::NORM_INF), 0);
    for (int l = 0; l < 2; ++l)
      EXPECT_EQ(cv::norm(fused.variance(l), lc.variance(l), cv::NORM_INF), 0) << "layer " << l;
  }
  const int taken = cv::countNonZero(choice);
  std::printf("thin bars: layer 1 (the bars' plane) taken at %d of %d pixels\n", taken, 320 * 240);
  // The choice against its definition, in doubles: the layers' variances
  // averaged over the window's pixels that layer 1 covers (each layer's
  // coverage: a plain composite's alpha).
  {
    std::vector<lf::FragmentPixels> only[2];
    for (const lf::FragmentPixels& p : px) only[p.fragment->layer].push_back(p);
    cv::Mat l0, l1;
    lf::Compositor().composite(320, 240, only[0], l0);
    lf::Compositor().composite(320, 240, only[1], l1);
    const cv::Mat v0 = lc.variance(0), v1 = lc.variance(1);
    const int R = lf::LayerCompositor::kChoiceWindow / 2;
    int agree = 0, decided = 0;
    for (int y = 0; y < 240; ++y)
      for (int x = 0; x < 320; ++x) {
        if (l1.at<cv::Vec4b>(y, x)[3] == 0) {
          EXPECT_EQ(choice.at<uint8_t>(y, x), 0);
          continue;
        }
        double s0 = 0, s1 = 0, n = 0;
        for (int j = std::max(0, y - R); j <= std::min(239, y + R); ++j)
          for (int i = std::max(0, x - R); i <= std::min(319, x + R); ++i)
            if (l1.at<cv::Vec4b>(j, i)[3] > 0)
              s0 += v0.at<float>(j, i), s1 += v1.at<float>(j, i), n += 1;
        s0 /= std::max(1.0, n), s1 /= std::max(1.0, n);
        const bool other =
            lf::LayerCompositor::kChoiceRatio * s0 + lf::LayerCompositor::kChoiceMargin < s1 &&
            l0.at<cv::Vec4b>(y, x)[3] > 0;
        agree += choice.at<uint8_t>(y, x) == (other ? 0 : 1), ++decided;
      }
    std::printf("thin bars: the choice agrees with its definition at %d of %d pixels\n", agree,
                decided);
    EXPECT_GT(decided, 1000);
    // A tie may round either way in float (none here); the rows beyond a
    // band of the box filter left out would disagree at 46 pixels.
    EXPECT_GE(agree, decided - decided / 10000);
  }
  EXPECT_GT(taken, 1000);
  EXPECT_LT(taken, 320 * 240 / 2);
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

// Every number of an estimate is finite: inverse depths, the planes'
// coefficients, and the view rendered through it.
void expect_finite(const lf::SurfaceEstimate& e, const char* what) {
  EXPECT_TRUE(std::isfinite(e.single_q)) << what;
  for (double v : {e.single.n[0], e.single.n[1], e.single.n[2], e.single.d})
    EXPECT_TRUE(std::isfinite(v)) << what;
  for (double q : e.tile_q) EXPECT_TRUE(std::isfinite(q)) << what;
  for (const lf::FocalPlane& pl : e.surface.planes)
    for (double v : {pl.n[0], pl.n[1], pl.n[2], pl.d}) EXPECT_TRUE(std::isfinite(v)) << what;
  EXPECT_GE(e.planes_used, 1) << what;
  EXPECT_LE(e.planes_used, lf::FocalSurface::kMaxPlanes) << what;
}

// `cam`'s image of a chequerboard on the plane z = depth, squares `square`
// rig units wide, grey levels 40 and 210.
cv::Mat chequerboard_image(const lf::Camera& cam, double depth, double square) {
  cv::Mat img(cam.height, cam.width, CV_8UC4, cv::Scalar(0, 0, 0, 255));
  const cv::Vec3d C = cam.center();
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const auto d = cam.unproject({double(x), double(y)});
      if (!d || !((*d)[2] > 1e-12)) continue;
      const cv::Vec3d X = C + *d * ((depth - C[2]) / (*d)[2]);
      const bool dark = (static_cast<long>(std::floor(X[0] / square)) +
                         static_cast<long>(std::floor(X[1] / square))) &
                        1;
      const uchar v = dark ? 40 : 210;
      img.at<cv::Vec4b>(y, x) = cv::Vec4b(v, v, v, 255);
    }
  return img;
}

// Repeated texture: a chequerboard whose period is 2/3 of the neighbour
// disparity, so that one baseline alone also matches at 2/3 of the true
// inverse depth and at infinity; the eye between cameras blends baselines
// that tell the true plane apart, so the sweep finds it and the picture
// matches a camera placed at the eye. (Known limit, not tested here: an eye
// whose blended cameras are all an even number of half-periods apart, such
// as the centre of a held-out camera's hole in this rig, sees the
// chequerboard agree at infinity too, and the tent's cameras cannot tell the
// two apart; a wider aperture's baselines could.)
TEST(Surface, ARepeatedTextureDoesNotLockOntoAnAlias) {
  const lf::Rig rig = small_rig();
  const double depth = 1.5, f = rig.cameras[0].intrinsics.fx;
  const double disparity = f * 0.1 / depth;                 // neighbours, pixels
  const double square = (disparity / 1.5) / 2 * depth / f;  // a period = 2 squares
  std::vector<cv::Mat> images;
  for (const auto& c : rig.cameras) images.push_back(chequerboard_image(c, depth, square));
  // The eye between cameras 12, 13 and 17, and a camera there for the truth.
  lf::Camera eye = rig.cameras[12];
  eye.extrinsics = lf::Extrinsics::from_center(
      eye.extrinsics.R, rig.cameras[12].center() + cv::Vec3d(0.037, 0.021, 0));
  lf::ViewRequest req;
  req.view = lf::VirtualView::from_camera(eye, 320, 240);
  const cv::Mat truth =
      lf::camera_view_image(eye, chequerboard_image(eye, depth, square), 320, 240);
  const lf::FocalSurfaceEstimator est(rig, images);
  const lf::SurfaceEstimate e = est.estimate(req);
  expect_finite(e, "chequerboard");
  const double step = est.candidate_q(1);
  int ok = 0, n = 0;
  for (size_t k = 0; k < e.tile_q.size(); ++k)
    if (e.textured[k]) ++n, ok += std::abs(e.tile_q[k] - 1 / depth) <= step;
  auto psnr_of = [&](lf::ViewRequest r) {
    return lf::psnr(lf::render_view(rig, images, r), truth, r.view.height / 40);
  };
  lf::ViewRequest at_truth = req, at_alias = req, through = req;
  at_truth.focal_plane = lf::FocalPlane::through({0, 0, depth}, {0, 0, 1});
  at_alias.focal_plane = lf::FocalPlane::through({0, 0, 1.5 * depth}, {0, 0, 1});
  lf::apply(e, through);
  const double pt = psnr_of(at_truth), pa = psnr_of(at_alias), ps = psnr_of(through);
  std::printf(
      "chequerboard: single q %.4f (truth %.4f, alias %.4f), %d of %d tiles within a step, %d "
      "planes; PSNR %.2f dB (true plane %.2f, alias %.2f; hard edges resampled at sub-pixel "
      "offsets bound them)\n",
      e.single_q, 1 / depth, 2 / (3 * depth), ok, n, e.planes_used, ps, pt, pa);
  EXPECT_NEAR(e.single_q, 1 / depth, step);
  ASSERT_GT(n, 100);
  EXPECT_GE(ok, 0.95 * n);
  EXPECT_GT(ps, pt - 0.5);
  EXPECT_LT(pa, pt - 3.0) << "the alias plane must give a visibly worse picture";
}

// The eye exactly at a camera's centre sees that camera alone (the tent's
// weight is 1 there, whatever the focal surface), so the view reproduces
// its image; an eye outside the array, and saturated or dark images, give
// finite estimates and no picture worse than the single plane's.
TEST(Surface, EyeAtACameraOrOutsideTheArrayAndSaturatedImages) {
  const lf::Rig rig = small_rig();
  const std::vector<cv::Mat> images = plane_images(rig, 3.0);
  {
    lf::ViewRequest req;
    req.view = lf::VirtualView::from_camera(rig.cameras[12], 320, 240);
    const lf::SurfaceEstimate e = lf::FocalSurfaceEstimator(rig, images).estimate(req);
    expect_finite(e, "eye at a camera");
    lf::apply(e, req);
    const cv::Mat out = lf::render_view(rig, images, req);
    const cv::Mat truth = lf::camera_view_image(rig.cameras[12], images[12], 320, 240);
    const double p = lf::psnr(out, truth, 6);
    std::printf("eye at camera 12: PSNR %.2f dB against its image\n", p);
    EXPECT_GT(p, 45.0);
  }
  {
    lf::ViewRequest req;
    // Two spacings beyond the array's right edge, on the camera plane.
    req.view = lf::VirtualView::from_camera(rig.cameras[14], 320, 240);
    req.view.position += cv::Vec3d(0.2, 0, 0);
    const lf::SurfaceEstimate e = lf::FocalSurfaceEstimator(rig, images).estimate(req);
    expect_finite(e, "eye outside the array");
    lf::apply(e, req);
    const cv::Mat out = lf::render_view(rig, images, req);
    ASSERT_EQ(out.type(), CV_8UC4);
    // An eye on the plane outside the triangulation is weighed as at the
    // nearest point of it (camera 14): its picture, not a black one.
    std::vector<cv::Mat> ch;
    cv::split(out, ch);
    const double covered = cv::countNonZero(ch[3]) / static_cast<double>(out.total());
    std::printf("eye outside the array: %.1f %% of the view covered\n", 100 * covered);
    EXPECT_GT(covered, 0.6);
    // Just outside a border edge (between cameras 4 and 9, 1e-4 spacings
    // out, as an in-between camera of a sparser grid whose border cameras
    // are not exactly in a line): as just inside it.
    lf::ViewRequest in, out_req;
    const cv::Vec2d a = rig.plane_positions()[4], b = rig.plane_positions()[9];
    cv::Vec2d centre(0, 0);
    for (const cv::Vec2d& q : rig.plane_positions()) centre += q * (1.0 / rig.cameras.size());
    const cv::Vec2d mid = (a + b) * 0.5;
    const cv::Vec2d across = (mid - centre) * (rig.typical_spacing() / cv::norm(mid - centre));
    for (auto [r, side] : {std::pair{&in, -1e-4}, std::pair{&out_req, 1e-4}}) {
      r->view = lf::VirtualView::from_camera(rig.cameras[14], 320, 240);
      const cv::Vec2d p = mid + across * side;
      r->view.position = rig.plane().origin + rig.plane().u * p[0] + rig.plane().v * p[1];
      r->focal_plane = lf::plane_at_inverse_depth(rig, 1 / 3.0);
    }
    const cv::Mat inside = lf::render_view(rig, images, in);
    const cv::Mat beyond = lf::render_view(rig, images, out_req);
    const double p = lf::psnr(beyond, inside, 6);
    std::printf("eye 1e-4 spacings outside a border edge: PSNR %.2f dB against just inside\n", p);
    EXPECT_GT(p, 40.0);
  }
  for (int v : {255, 0, 3}) {
    std::vector<cv::Mat> flat(rig.cameras.size(),
                              cv::Mat(240, 320, CV_8UC4, cv::Scalar(v, v, v, 255)));
    const Held h = hold_out(rig, flat, 12, 320, 240);
    const lf::SurfaceEstimate e = lf::FocalSurfaceEstimator(h.rig, h.images).estimate(h.req);
    expect_finite(e, v == 255 ? "saturated" : "dark");
    EXPECT_TRUE(e.surface.empty()) << "level " << v << ": " << e.planes_used << " planes";
  }
  // Half the image saturated (a blown-out sky over a textured plane): the
  // textured half decides, the saturated half keeps the single plane.
  {
    std::vector<cv::Mat> half = images;
    for (auto& m : half) {
      m = m.clone();
      m(cv::Rect(0, 0, m.cols, m.rows / 2)).setTo(cv::Scalar(255, 255, 255, 255));
    }
    const Held h = hold_out(rig, half, 12, 320, 240);
    const lf::FocalSurfaceEstimator est(h.rig, h.images);
    const lf::SurfaceEstimate e = est.estimate(h.req);
    expect_finite(e, "half saturated");
    EXPECT_NEAR(e.single_q, 1 / 3.0, est.candidate_q(1));
    EXPECT_GT(psnr_with(h, e), psnr_at(h, e.single) - 0.2);
  }
}

// Rigs of 1, 2 and 3 cameras, in a row and not: the estimator either
// refuses them with std::invalid_argument or gives finite estimates, and
// renders through them stay finite.
TEST(Surface, TinyAndCollinearRigs) {
  struct Case {
    const char* name;
    lf::Rig rig;
  };
  const lf::Rig g = small_rig();
  std::vector<Case> cases = {
      {"1 camera", lf::synthetic_grid_rig(1, 1, 0.1, 320, 240, 40)},
      {"2 in a row", lf::synthetic_grid_rig(1, 2, 0.1, 320, 240, 40)},
      {"3 in a row", lf::synthetic_grid_rig(1, 3, 0.1, 320, 240, 40)},
      {"5 in a column", lf::synthetic_grid_rig(5, 1, 0.1, 320, 240, 40)},
      {"3 not in a row", lf::synthetic_grid_rig(2, 2, 0.1, 320, 240, 40).without({3})}};
  for (const Case& c : cases) {
    const std::vector<cv::Mat> images = plane_images(c.rig, 3.0);
    lf::ViewRequest req;
    req.view = lf::VirtualView::from_camera(c.rig.cameras[0], 320, 240);
    req.view.position += c.rig.plane().u * 0.03 + c.rig.plane().v * 0.02;
    try {
      const lf::FocalSurfaceEstimator est(c.rig, images);
      const lf::SurfaceEstimate e = est.estimate(req);
      expect_finite(e, c.name);
      lf::apply(e, req);
      const cv::Mat out = lf::render_view(c.rig, images, req);
      EXPECT_EQ(out.type(), CV_8UC4) << c.name;
      std::printf("%s: single q %.4f (truth %.4f), %d planes\n", c.name, e.single_q, 1 / 3.0,
                  e.planes_used);
      // With two cameras or more the plane is measured, not guessed.
      if (c.rig.cameras.size() >= 2) {
        EXPECT_NEAR(e.single_q, 1 / 3.0, est.candidate_q(1)) << c.name;
      }
    } catch (const std::invalid_argument& ex) {
      std::printf("%s: refused: %s\n", c.name, ex.what());
      EXPECT_LT(c.rig.cameras.size(), 2u) << c.name << " refused: " << ex.what();
    }
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
    EXPECT_EQ(e.planes_evaluated, frame == 0 ? swept(opt) : swept(opt) / 4) << frame;
    EXPECT_EQ(e.surface.plane_of, scratch.surface.plane_of) << frame;
    EXPECT_EQ(e.tile_q, scratch.tile_q) << frame;
  }
  // Another view size starts afresh.
  lf::ViewRequest small = h.req;
  small.view = lf::VirtualView::from_camera(rig.cameras[12], 160, 120);
  EXPECT_EQ(est.estimate(small, &carry).planes_evaluated, swept(opt));
}

TEST(Surface, AFullSurfaceTakesNoMoreThinPlanes) {
  // Hysteresis may fill a surface with kept depths (a tile keeps the last
  // estimate's depth unless clearly worse: here always); thin structures
  // found then add no plane beyond FocalSurface::kMaxPlanes, so the
  // request stays valid.
  const OffPlaneView v(6, 20);
  lf::SurfaceOptions opt;
  opt.change_penalty = 1e9;
  const lf::FocalSurfaceEstimator est(v.rig, v.images, opt);
  lf::SurfaceCosts carry;
  const lf::SurfaceEstimate first = est.estimate(v.req, &carry);
  ASSERT_GT(first.thin_tiles, 10);
  for (size_t t = 0; t < carry.prior.tile_q.size(); ++t)
    carry.prior.tile_q[t] = first.tile_q[t] * (1 + 1e-3 * static_cast<double>(t % 97));
  const lf::SurfaceEstimate full = est.estimate(v.req, &carry);
  EXPECT_EQ(full.surface.planes.size(), static_cast<size_t>(lf::FocalSurface::kMaxPlanes));
  lf::ViewRequest r = v.req;
  lf::apply(full, r);
  EXPECT_NO_THROW(lf::validate(r));
  EXPECT_GT(v.psnr(r), 20.0);
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
  refused([](lf::SurfaceOptions& o) { o.thin_ratio = 0; });
  refused([](lf::SurfaceOptions& o) { o.thin_ratio = 1.5; });
  refused([](lf::SurfaceOptions& o) { o.thin_margin = NAN; });
  refused([](lf::SurfaceOptions& o) { o.thin_fraction = -0.1; });
  refused([](lf::SurfaceOptions& o) { o.thin_neighbours = 9; });
  refused([](lf::SurfaceOptions& o) { o.sub_steps = 0; });
  refused([](lf::SurfaceOptions& o) { o.sub_steps = 9; });
  EXPECT_THROW(lf::FocalSurfaceEstimator(rig, {images[0]}), std::invalid_argument);
}

// SurfaceOptions::sub_steps: a tile whose costs' minimum lies between two
// planes moves towards it by the parabola's vertex, rounded to a 1/N step.
// Hand-made costs on 6 x 4 tiles over 9 planes 0.1 apart: the left half's
// parabola has its vertex at plane 2.3, the right half's on plane 6; the
// costs are quadratic, so the vertex is exact.
TEST(Surface, SubStepsMoveATileToTheVertexBetweenItsPlanes) {
  const lf::Rig rig = small_rig();
  const int cols = 6, rows = 4, tiles = cols * rows, M = 9;
  lf::SweepCosts c;
  for (int k = 0; k < M; ++k) c.qs.push_back(0.1 * k);
  c.sum.resize(static_cast<size_t>(M) * tiles);
  c.count.assign(c.sum.size(), 100.0);
  for (int k = 0; k < M; ++k)
    for (int t = 0; t < tiles; ++t) {
      const double vertex = t % cols < 3 ? 2.3 : 6.0;
      c.sum[static_cast<size_t>(k) * tiles + t] = 100.0 * 20.0 * (k - vertex) * (k - vertex);
    }
  auto estimate = [&](int sub_steps) {
    lf::SurfaceOptions o;
    o.sub_steps = sub_steps;
    return lf::surface_from_costs(rig, c, cols, rows, NAN, 50.0, o);
  };
  const lf::SurfaceEstimate planes = estimate(1), thirds = estimate(3), halves = estimate(2);
  for (int r = 0; r < rows; ++r)
    for (int q : {0, 1, 4, 5}) {  // away from the halves' edge
      const int t = r * cols + q;
      if (q < 3) {
        EXPECT_NEAR(planes.tile_q[t], 0.2, 1e-12) << t;
        EXPECT_NEAR(thirds.tile_q[t], 0.2 + 0.1 / 3, 1e-12) << t;  // 0.3 * 3 rounds to 1
        EXPECT_NEAR(halves.tile_q[t], 0.25, 1e-12) << t;           // 0.3 * 2 rounds to 1
      } else {
        for (const lf::SurfaceEstimate* e : {&planes, &thirds, &halves})
          EXPECT_NEAR(e->tile_q[t], 0.6, 1e-12) << t;  // on its plane: stays
      }
      // The tile's plane is the one at its depth.
      const lf::FocalPlane& fp = thirds.surface.planes[thirds.surface.plane_of[t]];
      const lf::FocalPlane want = lf::plane_at_inverse_depth(rig, thirds.tile_q[t]);
      EXPECT_NEAR(fp.d, want.d, 1e-9 * std::abs(want.d)) << t;
    }
  // The left half's tiles share one plane (2 1/3); the tiles at the halves'
  // edge, whose costs mix both halves', may add a few more (3 here).
  for (int r = 0; r < rows; ++r)
    EXPECT_EQ(thirds.surface.plane_of[r * cols], thirds.surface.plane_of[0]) << r;
  EXPECT_GT(thirds.surface.planes.size(), planes.surface.planes.size());
  EXPECT_LE(thirds.surface.planes.size(), planes.surface.planes.size() + 2 * 4);
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

// Every camera's answer to every step of a surface probe of `h.req`,
// rendered by the library as lffragment renders it.
lf::SurfaceProbeAnswers answer_probe(const Held& h, const lf::SurfaceOptions& opt = {},
                                     int skip_camera = -1, int skip_from_step = 0) {
  lf::SurfaceProbeAnswers answers(h.req.view.width, h.req.view.height, opt);
  for (const lf::ViewRequest& r : lf::surface_probe_requests(h.rig, h.req, 7, opt)) {
    const lf::ViewGeometry g(h.rig, r);
    for (size_t i = 0; i < h.rig.cameras.size(); ++i) {
      const int step = lf::surface_probe_step(r.sequence);
      if (static_cast<int>(i) == skip_camera && step >= skip_from_step) continue;
      lf::Fragment f;
      lf::render_fragment(lf::plan_fragment(g, static_cast<int>(i)), h.rig.cameras[i], h.images[i],
                          f);
      EXPECT_TRUE(answers.add(step, f));
    }
  }
  return answers;
}

TEST(SurfaceProbe, RequestsAreTheViewAtLowResolutionOncePerPlane) {
  const Held h = disc_scene(0.3);
  lf::ViewRequest view = h.req;
  view.view.width = 640, view.view.height = 480;
  const lf::SurfaceOptions opt;
  const auto reqs = lf::surface_probe_requests(h.rig, view, 0xabcdef12u, opt);
  ASSERT_EQ(reqs.size(), static_cast<size_t>(opt.planes));
  const double q_max = lf::sweep_q_max(h.rig, opt);
  for (int k = 0; k < opt.planes; ++k) {
    const lf::ViewRequest& r = reqs[k];
    EXPECT_EQ(r.view.width, 160);
    EXPECT_EQ(r.view.height, 120);
    EXPECT_NEAR(r.view.vfov_deg, view.view.vfov_deg, 1e-9);
    EXPECT_LT(cv::norm(r.view.position - view.view.position), 1e-12);
    EXPECT_TRUE(lf::is_surface_probe(r.sequence));
    EXPECT_FALSE(lf::is_focus_probe(r.sequence));
    EXPECT_LT(r.sequence >> 62, 2u);  // never a frame request's (those stay below 2^62)
    EXPECT_GE(r.sequence, uint64_t{1} << 62);
    EXPECT_EQ(lf::surface_probe_id(r.sequence), 0xabcdef12u);
    EXPECT_EQ(lf::surface_probe_step(r.sequence), k);
    EXPECT_NEAR(lf::inverse_depth_of(h.rig, r.focal_plane), q_max * k / (opt.planes - 1), 1e-9);
  }
  EXPECT_FALSE(lf::is_surface_probe(lf::surface_probe_sequence(1, 64)));
  EXPECT_FALSE(lf::is_surface_probe(5));
}

TEST(SurfaceProbe, FromTheCamerasFragmentsFindsTheDiscAndTheBackground) {
  // The same scene as TwoDepths..., but the costs come from fragments that
  // each camera rendered for each plane (what a compositor receives).
  const Held h = disc_scene(0.3);
  const lf::SurfaceProbeAnswers answers = answer_probe(h);
  EXPECT_EQ(answers.complete_cameras(), static_cast<int>(h.rig.cameras.size()));
  EXPECT_EQ(answers.steps(), lf::SurfaceOptions{}.planes);
  bool ok = false;
  const lf::SurfaceEstimate e = answers.estimate(h.rig, &ok);
  ASSERT_TRUE(ok);
  const double step = lf::sweep_q_max(h.rig, {}) / (lf::SurfaceOptions{}.planes - 1);
  ASSERT_FALSE(e.surface.empty());
  const DiscTiles d = disc_tiles(e, step, 0.3);
  lf::ViewRequest q = h.req;
  const double p_auto = psnr_at(h, lf::AutofocusContext(h.rig, h.images).run(q).plane);
  const double p_probe = psnr_with(h, e);
  const double p_images = psnr_with(h, lf::FocalSurfaceEstimator(h.rig, h.images).estimate(h.req));
  std::printf(
      "disc from fragments: %d planes; disc tiles %d/%d within a step, background %d/%d; PSNR "
      "auto %.2f dB, probe surface %.2f dB, estimator from the images %.2f dB\n",
      e.planes_used, d.near_ok, d.near_n, d.far_ok, d.far_n, p_auto, p_probe, p_images);
  // Measured: 32 of 38 disc tiles (one pass of coarse planes: the
  // estimator's finer second pass gets 35), 230 of 230 background tiles;
  // +10.1 dB over auto-focus, 1.11 dB below the estimator (whose thin
  // structure votes are at 320 pixels wide, the probe's at 160).
  expect_two_depths(e, d, 0.8);
  EXPECT_GT(p_probe, p_auto + 3.0);
  EXPECT_GT(p_probe, p_images - 1.5);
  // The steps' costs are gathered on every core: the estimate is the one
  // thread's, value for value (a non-live pipeline is reproducible), both
  // on the calling thread alone and with OpenCV held to one thread.
  // (OpenCV's threads restored before anything is asserted.)
  bool ok_alone = false, ok_one = false;
  const lf::SurfaceEstimate alone = answers.estimate(h.rig, &ok_alone, nullptr, false);
  const int threads = cv::getNumThreads();
  cv::setNumThreads(1);
  const lf::SurfaceEstimate one_thread = answers.estimate(h.rig, &ok_one, nullptr, true);
  cv::setNumThreads(threads);
  for (const lf::SurfaceEstimate* one : {&alone, &one_thread}) {
    EXPECT_EQ(one->tile_q, e.tile_q);
    EXPECT_EQ(one->textured, e.textured);
    EXPECT_EQ(one->surface.plane_of, e.surface.plane_of);
    EXPECT_EQ(one->surface.second_of, e.surface.second_of);
    EXPECT_EQ(one->two_plane_tiles, e.two_plane_tiles);
  }
  EXPECT_TRUE(ok_alone);
  EXPECT_TRUE(ok_one);
}

// Surface probes of a still view, each from new sensor noise (sigma 2
// levels): with the last estimate as the prior (what lf::ProbeScoring keeps
// per viewer), a tile changes depth only when the new plane is clearly
// better; without, noise moves tiles between planes of nearly equal cost.
// The disc is found either way.
TEST(SurfaceProbe, TheLastEstimateAsThePriorKeepsTilesSteady) {
  const Held clean = disc_scene(0.3);
  auto noisy = [&](int seed) {
    Held h = clean;
    cv::RNG rng(seed);
    for (cv::Mat& m : h.images) {
      cv::Mat n(m.size(), CV_32FC4), out;
      rng.fill(n, cv::RNG::NORMAL, 0, 2.0);
      m.convertTo(out, CV_32FC4);
      out += n;
      out.convertTo(m, CV_8UC4);
    }
    return h;
  };
  const int cols = 20, rows = 15;
  lf::SurfacePrior prior, none;
  std::vector<double> last_with, last_without;
  int changed_with = 0, changed_without = 0, kept = 0;
  const double step = lf::sweep_q_max(clean.rig, {}) / (lf::SurfaceOptions{}.planes - 1);
  for (int probe = 0; probe < 8; ++probe) {
    const Held h = noisy(500 + probe);
    const lf::SurfaceProbeAnswers answers = answer_probe(h);
    bool ok = false;
    const lf::SurfaceEstimate with = answers.estimate(h.rig, &ok, &prior);
    ASSERT_TRUE(ok);
    const lf::SurfaceEstimate without = answers.estimate(h.rig, &ok, &none);
    kept += with.kept_tiles;
    for (size_t t = 0; probe > 0 && t < with.tile_q.size(); ++t) {
      changed_with += std::abs(with.tile_q[t] - last_with[t]) > 0.5 * step;
      changed_without += std::abs(without.tile_q[t] - last_without[t]) > 0.5 * step;
    }
    last_with = with.tile_q, last_without = without.tile_q;
    prior = lf::prior_of(with, cols, rows);
    ASSERT_TRUE(prior.fits(cols, rows));
    if (probe == 7) expect_two_depths(with, disc_tiles(with, step, 0.3), 0.8);
  }
  std::printf(
      "8 probes of a still view with new noise: tile-changes of half a plane or more %d with the "
      "prior, %d without (%d tiles kept their depth)\n",
      changed_with, changed_without, kept);
  EXPECT_GT(changed_without, 0) << "the noise must move some tiles, or this shows nothing";
  EXPECT_LE(changed_with, changed_without / 2);
}

// A tile that keeps the prior's depth may keep the depth of a neighbour's
// new plane. Its second plane comes from the depths the tiles have, so it
// is never the tile's own plane: the request stays valid. (It was once the
// neighbour's new label's plane, lf::validate refused the surface, and
// lfviewrequest ignored nearly every re-estimated surface of the live
// pipeline: tests/test_gst.cpp WholeViewModeDefersLayerPairs.)
TEST(SurfaceProbe, ATileThatKeptItsDepthGetsNoSecondPlaneOfItsOwn) {
  const Held h = disc_scene(0.3);
  lf::SurfaceOptions opt;
  opt.change_penalty = 1e9;  // every tile keeps the prior's depth
  const lf::SurfaceProbeAnswers answers = answer_probe(h, opt);
  bool ok = false;
  lf::SurfacePrior none;
  const lf::SurfaceEstimate first = answers.estimate(h.rig, &ok, &none);
  ASSERT_TRUE(ok);
  ASSERT_GT(first.two_plane_tiles, 0);
  // The prior: each tile at the depth of its neighbour furthest in depth
  // (a tile by the disc's edge had the depth across it).
  const int cols = first.surface.cols, rows = first.surface.rows;
  lf::SurfacePrior prior = lf::prior_of(first, cols, rows);
  ASSERT_TRUE(prior.fits(cols, rows));
  const std::vector<double>& q = first.tile_q;
  for (int t = 0; t < cols * rows; ++t) {
    int far = t;
    for (int dr = -1; dr <= 1; ++dr)
      for (int dc = -1; dc <= 1; ++dc) {
        const int r = t / cols + dr, c = t % cols + dc;
        if (r >= 0 && c >= 0 && r < rows && c < cols &&
            std::abs(q[r * cols + c] - q[t]) > std::abs(q[far] - q[t]))
          far = r * cols + c;
      }
    prior.tile_q[t] = q[far];
  }
  const lf::SurfaceEstimate next = answers.estimate(h.rig, &ok, &prior);
  ASSERT_TRUE(ok);
  std::printf("%d tiles kept the prior's depth, %d have two planes\n", next.kept_tiles,
              next.two_plane_tiles);
  EXPECT_GT(next.kept_tiles, 20);
  EXPECT_GT(next.two_plane_tiles, 20);
  const lf::FocalSurface& fs = next.surface;
  ASSERT_EQ(fs.second_of.size(), fs.plane_of.size());
  for (size_t t = 0; t < fs.plane_of.size(); ++t)
    if (fs.second_of[t] != lf::FocalSurface::kNone) {
      EXPECT_NE(fs.second_of[t], fs.plane_of[t]) << t;
    }
  lf::ViewRequest r = h.req;
  lf::apply(next, r);
  EXPECT_NO_THROW(lf::validate(r));
}

TEST(SurfaceProbe, LateCamerasRepeatsAndStrangersAreLeftOut) {
  const Held h = disc_scene(0.3);
  // Camera 3 answered only the first 10 steps: it is not scored.
  const lf::SurfaceProbeAnswers answers = answer_probe(h, {}, 3, 10);
  EXPECT_EQ(answers.complete_cameras(), static_cast<int>(h.rig.cameras.size()) - 1);
  bool ok = false;
  const lf::SurfaceEstimate e = answers.estimate(h.rig, &ok);
  EXPECT_TRUE(ok);
  EXPECT_GE(e.planes_used, 2);
  // Refused: a repeat, a step out of range, another size.
  lf::SurfaceProbeAnswers a(320, 240);
  lf::Fragment f;
  f.camera_id = 1, f.out_width = 160, f.out_height = 120;
  EXPECT_TRUE(a.add(0, f));
  EXPECT_FALSE(a.add(0, f));
  EXPECT_FALSE(a.add(-1, f));
  EXPECT_FALSE(a.add(lf::SurfaceOptions{}.planes, f));
  f.out_width = 320;
  EXPECT_FALSE(a.add(1, f));
  EXPECT_EQ(a.fragments(), 1u);
  // The pixel budget: kMaxOverlap x the probe's pixels per plane. Whole
  // 160x120 fragments from more and more cameras: refused past it.
  lf::SurfaceProbeAnswers full(320, 240);
  lf::Fragment whole;
  whole.out_width = 160, whole.out_height = 120, whole.rect = cv::Rect(0, 0, 160, 120);
  whole.spans.assign(120, {0, 160});
  whole.pixels.assign(160 * 120 * 4, 128);
  size_t kept = 0;
  for (uint32_t cam = 0; cam < 8; ++cam)
    for (int step = 0; step < lf::SurfaceOptions{}.planes; ++step) {
      whole.camera_id = cam;
      kept += full.add(step, whole);
    }
  EXPECT_EQ(kept, lf::SurfaceProbeAnswers::kMaxOverlap * lf::SurfaceOptions{}.planes);
  // Too few planes answered: no surface, and it says so.
  const lf::SurfaceEstimate none = a.estimate(h.rig, &ok);
  EXPECT_FALSE(ok);
  EXPECT_TRUE(none.surface.empty());
  EXPECT_THROW(lf::SurfaceProbeAnswers(1, 240), std::invalid_argument);
}

TEST(Surface, StanfordChessLeaveOneOutBeatsAutoFocus) {
  LF_NEEDS_DATA("stanford-chess");
  // As RealData.StanfordChessLeaveOneOut: 8x8 block, half-resolution images,
  // 320x240 output, four interior cameras held out in turn.
  const lf::Rig rig = lf::scale_rig(
      lf::grid_block(lf::import_dataset(data_path("stanford-chess")), 0, 0, 8, 8), 0.5);
  const auto images = lf::load_images(rig);
  double gain = 0, probe_gain = 0;
  for (auto [r, c] : {std::pair{2, 3}, {3, 5}, {5, 2}, {4, 4}}) {
    const Held h = hold_out(rig, images, rig.grid.at(r, c), 320, 240);
    lf::ViewRequest q = h.req;
    const double p_auto = psnr_at(h, lf::AutofocusContext(h.rig, h.images).run(q).plane);
    const lf::SurfaceEstimate e = lf::FocalSurfaceEstimator(h.rig, h.images).estimate(h.req);
    const double p = psnr_with(h, e);
    // The same from the cameras' fragments (a surface probe, one pass).
    const lf::SurfaceEstimate ep = answer_probe(h).estimate(h.rig);
    const double pp = psnr_with(h, ep);
    std::printf(
        "chess r%dc%d: auto %.2f dB, surface %.2f dB (%d planes), from a probe %.2f dB (%d "
        "planes)\n",
        r, c, p_auto, p, e.planes_used, pp, ep.planes_used);
    gain += (p - p_auto) / 4;
    probe_gain += (pp - p_auto) / 4;
    EXPECT_GT(p, p_auto + 3.5);   // measured +4.8 .. +5.1 dB
    EXPECT_GT(pp, p_auto + 3.5);  // measured +4.4 .. +4.8 dB
    EXPECT_GT(pp, p - 1.0);       // measured 0.28 .. 0.53 dB below the two-pass estimator
  }
  EXPECT_GT(gain, 4.0);
  EXPECT_GT(probe_gain, 4.0);  // measured +4.63 dB
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

// The estimator's two planes for `v`, and what they render: PSNR with the
// second planes and without them, fragment pixels of each.
struct ThinResult {
  lf::SurfaceEstimate e;
  double p1 = 0, p2 = 0, px1 = 0, px2 = 0;
};
ThinResult render_both(const OffPlaneView& v, const lf::SurfaceEstimate& e) {
  ThinResult out{e};
  lf::ViewRequest one = v.req, two = v.req;
  lf::apply(e, two);
  lf::apply(e, one);
  one.surface.second_of.clear();
  lf::RenderStats s1, s2;
  out.p1 = v.psnr(one, &s1), out.p2 = v.psnr(two, &s2);
  out.px1 = s1.fragment_pixels / (320.0 * 240), out.px2 = s2.fragment_pixels / (320.0 * 240);
  return out;
}

TEST(Surface, ThinBarsInsideTilesGetTheirSecondPlane) {
  // Bars 6 pixels wide, about 20 apart: no tile has a neighbour at the bars'
  // depth (every tile is mostly background), so only the per-cell votes can
  // find them, from the images and from the cameras' probe fragments.
  const OffPlaneView v(6, 20);
  lf::SurfaceOptions opt;
  opt.second_planes = true;
  const ThinResult im =
      render_both(v, lf::FocalSurfaceEstimator(v.rig, v.images, opt).estimate(v.req));
  const lf::SurfaceProbeAnswers answers = answer_probe(Held{v.rig, v.images, v.req, v.truth}, opt);
  bool ok = false;
  const ThinResult pr = render_both(v, answers.estimate(v.rig, &ok));
  ASSERT_TRUE(ok);
  for (const auto& [what, r] : {std::pair{"images", &im}, std::pair{"probe", &pr}}) {
    const int tiles = r->e.surface.cols * r->e.surface.rows;
    std::printf(
        "thin bars from the %s: %d of %d tiles with a second plane (%d for thin structures); "
        "PSNR one plane per tile %.2f dB, two %.2f dB; fragment pixels %.2fx -> %.2fx the "
        "output\n",
        what, r->e.two_plane_tiles, tiles, r->e.thin_tiles, r->p1, r->p2, r->px1, r->px2);
    // Measured from the images: 73 of 300 tiles, 28.94 -> 37.27 dB, 3.00x
    // -> 3.74x; from the probe (one pass, at 160x120): 65 tiles, 28.12 ->
    // 37.73 dB, 3.65x. Without SurfaceOptions::thin_spread: 42 tiles, 35.80 dB
    // from the images (37 tiles from the probe).
    EXPECT_GT(r->e.thin_tiles, 15) << what;
    EXPECT_LT(r->e.thin_tiles, tiles / 3) << what;
    EXPECT_GT(r->p2, r->p1 + (r == &im ? 4.5 : 2.5)) << what;
    EXPECT_LT(r->px2, 1.25 * r->px1) << what;
  }
  // The bars' plane, within two steps of the sweep: the second plane of
  // most thin tiles.
  const double q_bars = 1.0 / v.scene.near_depth,
               step = lf::sweep_q_max(v.rig, opt) / (opt.planes - 1);
  int near_bars = 0;
  for (size_t t = 0; t < im.e.surface.second_of.size(); ++t)
    if (im.e.surface.second_of[t] != lf::FocalSurface::kNone &&
        std::abs(lf::inverse_depth_of(v.rig, im.e.surface.planes[im.e.surface.second_of[t]]) -
                 q_bars) < 2 * step)
      ++near_bars;
  EXPECT_GT(near_bars, im.e.two_plane_tiles * 3 / 4);
  // A bar on a tile border: without spreading to the tiles beside, fewer
  // tiles and less PSNR.
  lf::SurfaceOptions no_spread = opt;
  no_spread.thin_spread = false;
  const ThinResult off =
      render_both(v, lf::FocalSurfaceEstimator(v.rig, v.images, no_spread).estimate(v.req));
  std::printf("thin bars without spreading: %d thin tiles (with: %d), %.2f dB (with: %.2f dB)\n",
              off.e.thin_tiles, im.e.thin_tiles, off.p2, im.p2);
  EXPECT_LT(off.e.thin_tiles, im.e.thin_tiles * 3 / 4);
  EXPECT_GT(im.p2, off.p2 + 0.3);
  // Other widths and spacings: never worse than one plane per tile.
  for (const auto& [bar, pitch] :
       {std::pair{3.0, 20.0}, {4.0, 20.0}, {8.0, 20.0}, {10.0, 30.0}, {6.0, 40.0}, {12.0, 40.0}}) {
    const OffPlaneView w(bar, pitch);
    const ThinResult r =
        render_both(w, lf::FocalSurfaceEstimator(w.rig, w.images, opt).estimate(w.req));
    std::printf(
        "bars %2.0f px every %2.0f: %2d thin tiles of %d two-plane; %.2f -> %.2f dB (%+.2f); "
        "%.2fx -> %.2fx\n",
        bar, pitch, r.e.thin_tiles, r.e.two_plane_tiles, r.p1, r.p2, r.p2 - r.p1, r.px1, r.px2);
    EXPECT_GT(r.p2, r.p1 - 0.1) << bar << " px bars every " << pitch;
  }
  // A textured plane with noise gets no second plane, nor does the disc's
  // background (its rim tiles get theirs from the depth-edge rule).
  std::vector<cv::Mat> noisy = plane_images(v.rig, 3.0);
  cv::RNG rng(5);
  for (cv::Mat& m : noisy) {
    cv::Mat n(m.size(), CV_16SC4);
    rng.fill(n, cv::RNG::NORMAL, 0, 6);
    cv::Mat m16;
    m.convertTo(m16, CV_16SC4);
    cv::add(m16, n, m16);
    m16.convertTo(m, CV_8UC4);
  }
  const Held h = hold_out(v.rig, noisy, 12, 320, 240);
  const lf::SurfaceEstimate flat = lf::FocalSurfaceEstimator(h.rig, h.images, opt).estimate(h.req);
  EXPECT_EQ(flat.two_plane_tiles, 0);
  EXPECT_EQ(flat.thin_tiles, 0);
  const lf::SurfaceEstimate disc =
      lf::FocalSurfaceEstimator(v.rig, OffPlaneView().images, opt).estimate(v.req);
  std::printf("disc: %d thin tiles (of %d with a second plane)\n", disc.thin_tiles,
              disc.two_plane_tiles);
  EXPECT_LT(disc.thin_tiles, 5) << "the disc has no thin structure";
}

// Thin structures (issue 37, item 3): the default estimate (second planes,
// chosen per pixel by the compositor) against a per-pixel plane sweep
// (lf/quality/sweep.h: 64 planes, each pixel at the plane where the cameras
// agree best over a 9 x 9 window; it costs 64 renders of the view) and
// against one plane per tile. Test views: bars of 3.5-9 pixels every 16-36
// at t = 0.8 from two eyes behind the camera plane, in-between cameras; none
// of them was looked at while the method was built (that was done on
// OffPlaneView's own eye at t = 0.3, the test above).
TEST(Surface, ThinStructuresComeWithinHalfADecibelOfAPerPixelSweep) {
  double sum_default = 0, sum_one = 0, sum_sweep = 0, ms_estimate = 0, ms_sweep = 0;
  double px_default = 0, px_one = 0, sum_probe = 0, ms_probe = 0;
  int n = 0;
  for (const auto& [bar, pitch] :
       {std::pair{5.0, 24.0}, {7.0, 28.0}, {9.0, 36.0}, {3.5, 16.0}, {4.5, 30.0}})
    for (const cv::Vec3d& eye : {cv::Vec3d(-0.029, 0.043, -0.2), cv::Vec3d(0.013, -0.031, -0.25)}) {
      const OffPlaneView v(bar, pitch, eye, 0.8);
      const lf::FocalSurfaceEstimator est(v.rig, v.images);  // the defaults
      auto t0 = std::chrono::steady_clock::now();
      const lf::SurfaceEstimate e = est.estimate(v.req);
      ms_estimate +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const ThinResult r = render_both(v, e);
      const double p1 = r.p1, p2 = r.p2;
      // The live path: the cameras' probe fragments (160 x 120, one per
      // plane) and the estimate from them.
      t0 = std::chrono::steady_clock::now();
      const lf::SurfaceProbeAnswers answers = answer_probe(Held{v.rig, v.images, v.req, v.truth});
      bool ok = false;
      const lf::SurfaceEstimate pe = answers.estimate(v.rig, &ok);
      ms_probe +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      ASSERT_TRUE(ok);
      sum_probe += render_both(v, pe).p2;
      t0 = std::chrono::steady_clock::now();
      const lf::SweepResult sweep = lf::per_pixel_sweep(v.rig, v.images, v.req, 64, 9);
      ms_sweep +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const double ps = lf::psnr(sweep.image, v.truth, 6);
      std::printf(
          "bars %.1f px every %.0f, eye (%+.3f, %+.3f, %+.3f): default %.2f dB (%d thin tiles), "
          "one plane per tile %.2f dB, per-pixel sweep %.2f dB\n",
          bar, pitch, eye[0], eye[1], eye[2], p2, e.thin_tiles, p1, ps);
      EXPECT_GT(p2, p1 - 0.1) << "second planes never cost";
      sum_default += p2, sum_one += p1, sum_sweep += ps, ++n;
      px_default += r.px2, px_one += r.px1;
    }
  std::printf(
      "mean of %d views: default %.2f dB, one plane per tile %.2f dB, per-pixel sweep %.2f dB, "
      "from the cameras' probe %.2f dB; fragment pixels %.2fx one plane per tile's; estimate "
      "%.0f ms (from the probe: %.0f ms, its fragments included), sweep %.0f ms a view\n",
      n, sum_default / n, sum_one / n, sum_sweep / n, sum_probe / n, px_default / px_one,
      ms_estimate / n, ms_probe / n, ms_sweep / n);
  // Measured: default 35.14 dB (33.71 before SurfaceOptions::thin_spread,
  // the compositor's 7 x 7 choice and the edge-aware aggregation), one
  // plane per tile 30.01 dB, the sweep 34.29 dB: 0.85 dB above it; fragment
  // pixels 1.20x; from the cameras' probe (the live path) 34.01 dB, 0.28 dB
  // below the sweep, in 21 ms against the sweep's 111-114 ms (the estimate
  // from the images: 66-71 ms; 144 ms before its analysis ran on AVX2 and
  // planned each camera once per pass). The issue asks for 0.5 dB of the
  // sweep at a fraction of its cost.
  EXPECT_GT(sum_default / n, sum_sweep / n);
  EXPECT_GT(sum_probe / n, sum_sweep / n - 0.5);
  EXPECT_GT(sum_default / n, sum_one / n + 4.0);
  EXPECT_LT(px_default, 1.3 * px_one);
}

namespace {

// Flicker: the mean absolute difference between consecutive rendered
// frames (8-bit levels, colour channels, a border of 2.5 % of the height
// left out), averaged over the frames.
struct Flicker {
  double sum = 0;
  int n = 0;
  cv::Mat last;
  void add(const cv::Mat& bgra) {
    const int b = bgra.rows / 40;
    const cv::Mat in = bgra(cv::Rect(b, b, bgra.cols - 2 * b, bgra.rows - 2 * b));
    if (!last.empty()) {
      cv::Mat d;
      cv::absdiff(in, last, d);
      const cv::Scalar m = cv::mean(d);
      sum += (m[0] + m[1] + m[2]) / 3, ++n;
    }
    last = in.clone();
  }
  double mean() const { return n ? sum / n : 0; }
};

}  // namespace

// Steady in time: a static scene seen by cameras with sensor noise (sigma
// 2 levels, new every frame), rendered 100 frames from a still eye and from
// a slowly moving one, each frame re-estimating its focus from that frame's
// images (as a live stream does). The focal surface may not flicker more
// than the single auto-focused plane by more than the cameras' own noise
// (the mean absolute difference of a camera's consecutive frames). Its
// hysteresis (SurfaceOptions::change_penalty, on by default: each estimate
// has the last as its prior) is compared with none.
TEST(Surface, SteadyInTimeOnAStaticScene) {
  const lf::Rig rig = small_rig();
  const lf::SyntheticScene scene = lf::SyntheticScene::for_rig(rig);
  std::vector<cv::Mat> clean;
  for (const auto& c : rig.cameras) clean.push_back(scene.render(c, 0.0, false));
  const Held h = hold_out(rig, clean, 12, 320, 240);
  constexpr int kFrames = 100;
  constexpr double kSigma = 2.0;
  double camera_noise = 0;
  lf::SurfaceOptions off;  // the surface without hysteresis
  off.change_penalty = 0;
  for (const bool moving : {false, true}) {
    Flicker plane, surface, surface_off;
    lf::SurfaceCosts carry, carry_off;
    std::vector<double> last_q, last_q_off;
    int switches = 0, switches_off = 0, tiles = 0;
    double psnr = 0, psnr_off = 0;
    Flicker cam;
    // Tiles whose depth changed from the last estimate.
    auto count = [](const lf::SurfaceEstimate& e, std::vector<double>& last, int* n) {
      for (size_t t = 0; t < e.tile_q.size() && last.size() == e.tile_q.size(); ++t)
        *n += e.tile_q[t] != last[t];
      last = e.tile_q;
    };
    for (int f = 0; f < kFrames; ++f) {
      cv::RNG rng(1000 + f);
      std::vector<cv::Mat> noisy;
      for (const cv::Mat& m : h.images) {
        cv::Mat n(m.size(), CV_32FC4);
        rng.fill(n, cv::RNG::NORMAL, 0, kSigma);
        cv::Mat out;
        m.convertTo(out, CV_32FC4);
        out += n;
        out.convertTo(out, CV_8UC4);
        std::vector<cv::Mat> ch;
        cv::split(out, ch);
        ch[3].setTo(255);
        cv::merge(ch, out);
        noisy.push_back(out);
      }
      cam.add(noisy[0]);
      lf::ViewRequest req = h.req;
      if (moving) req.view.position += cv::Vec3d(0.0005 * f, 0, 0);  // 1/200 spacing a frame
      lf::ViewRequest p = req;
      p.focal_plane = lf::FocalPlane::infinity();
      p.focal_plane = lf::AutofocusContext(h.rig, noisy).run(p).plane;
      plane.add(lf::render_view(h.rig, noisy, p));
      lf::ViewRequest s = req, s_off = req;
      const lf::SurfaceEstimate e = lf::FocalSurfaceEstimator(h.rig, noisy).estimate(s, &carry);
      const lf::SurfaceEstimate e_off =
          lf::FocalSurfaceEstimator(h.rig, noisy, off).estimate(s_off, &carry_off);
      count(e, last_q, &switches);
      count(e_off, last_q_off, &switches_off);
      tiles += static_cast<int>(e.tile_q.size());
      lf::apply(e, s);
      lf::apply(e_off, s_off);
      const cv::Mat out = lf::render_view(h.rig, noisy, s);
      const cv::Mat out_off = lf::render_view(h.rig, noisy, s_off);
      surface.add(out);
      surface_off.add(out_off);
      if (!moving) {
        const int border = h.truth.rows / 40;
        psnr += lf::psnr(out, h.truth, border) / kFrames;
        psnr_off += lf::psnr(out_off, h.truth, border) / kFrames;
      }
    }
    camera_noise = cam.mean();
    std::printf(
        "flicker over %d frames, %s eye: plane %.3f, surface %.3f (without hysteresis %.3f) "
        "levels (a camera's own noise %.3f); tiles changing depth per estimate %.2f %% "
        "(without hysteresis %.2f %%)",
        kFrames, moving ? "moving" : "still", plane.mean(), surface.mean(), surface_off.mean(),
        camera_noise, 100.0 * switches / tiles, 100.0 * switches_off / tiles);
    if (!moving) std::printf("; PSNR %.2f dB (without %.2f dB)", psnr, psnr_off);
    std::printf("\n");
    EXPECT_LE(surface.mean(), plane.mean() + camera_noise) << (moving ? "moving" : "still");
    // Measured: within 3 % of the plane's, still and moving (deterministic:
    // fixed noise seeds); a tile switching planes from frame to frame
    // would show here first.
    EXPECT_LE(surface.mean(), 1.1 * plane.mean()) << (moving ? "moving" : "still");
    // Hysteresis: fewer tiles change depth (without it nearly all do: the
    // fine sweep's planes and the refined single plane move with the
    // noise), no more flicker (measured: 2 % less with a still eye, 0.2 %
    // more with the moving one, where the view itself changes), no worse
    // picture (measured: the same PSNR to 0.01 dB).
    EXPECT_LE(switches, switches_off / 2) << (moving ? "moving" : "still");
    EXPECT_LE(surface.mean(), (moving ? 1.01 : 1.0) * surface_off.mean())
        << (moving ? "moving" : "still");
    if (!moving) {
      EXPECT_GE(psnr, psnr_off - 0.1);
    }
  }
}
