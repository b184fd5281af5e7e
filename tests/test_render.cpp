// Fragment rendering and compositing against analytically rendered images of
// a textured plane (exact ground truth when the focal plane is that plane).
#include <gtest/gtest.h>

#include <atomic>
#include <opencv2/imgproc.hpp>
#include <random>

#include "lf/focus/focus.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/parse.h"
#include "lf/quality/quality.h"
#include "lf/quality/synthetic.h"
#include "lf/render/colour.h"
#include "lf/render/composite.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"
#include "lf/wire/wire.h"

namespace {

constexpr double kDepth = 10.0, kPeriod = 1.0;

lf::Camera camera_of(const lf::VirtualView& v) {
  lf::Camera c;
  c.width = v.width;
  c.height = v.height;
  c.intrinsics = v.intrinsics();
  c.extrinsics = lf::Extrinsics::from_center(v.R, v.position);
  return c;
}

// PSNR over pixels the render covered (alpha 255); also returns coverage.
double covered_psnr(const cv::Mat& out, const cv::Mat& truth, double* coverage = nullptr) {
  double se = 0;
  size_t n = 0;
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      const auto a = out.at<cv::Vec4b>(y, x), b = truth.at<cv::Vec4b>(y, x);
      if (a[3] != 255) continue;
      for (int c = 0; c < 3; ++c) se += (a[c] - b[c]) * (a[c] - b[c]);
      ++n;
    }
  if (coverage) *coverage = static_cast<double>(n) / (out.rows * out.cols);
  return n ? 10 * std::log10(255.0 * 255.0 * 3 * n / std::max(se, 1e-9)) : 0;
}

std::vector<cv::Mat> images_of(const lf::Rig& rig) {
  std::vector<cv::Mat> im;
  for (const auto& c : rig.cameras) im.push_back(lf::render_textured_plane(c, kDepth, kPeriod));
  return im;
}

lf::ViewRequest view_at(const cv::Vec3d& eye, const cv::Vec3d& target) {
  lf::ViewRequest r;
  r.view = lf::VirtualView::look_at(eye, target, {0, 1, 0}, 35, 200, 150);
  r.focal_plane = lf::FocalPlane::through({0, 0, kDepth}, {0, 0, 1});
  return r;
}

TEST(Render, MatchesAnalyticImageOfTheFocalPlane) {
  const lf::Rig rig = lf::synthetic_grid_rig(5, 5, 0.5, 240, 180, 50, 2.0, 4);
  const auto images = images_of(rig);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int k = 0; k < 6; ++k) {
    const cv::Vec3d eye(0.7 * u(rng), 0.7 * u(rng), k % 2 ? 0.0 : 1.5 * u(rng));
    const auto req = view_at(eye, {u(rng), u(rng), kDepth});
    lf::RenderStats st;
    const cv::Mat out = lf::render_view(rig, images, req, &st);
    const cv::Mat truth = lf::render_textured_plane(camera_of(req.view), kDepth, kPeriod);
    double cov;
    const double p = covered_psnr(out, truth, &cov);
    EXPECT_GT(cov, 0.9) << "view " << k;
    EXPECT_GT(p, 40.0) << "view " << k;
  }
}

// The f-number mapping (lf/geometry/view.h): a diameter and its full-frame f-number
// convert into each other; a 50 mm-equivalent view at f/2 has a 25 mm
// aperture; lengths other than mm, cm, m are not lengths.
TEST(View, FNumberMappingRoundTrips) {
  const int width = 720;
  const double fx = 50.0 / 36.0 * width;  // 50 mm on a 36 mm wide sensor
  EXPECT_NEAR(lf::diameter_for_f_number(2.0, fx, width, 1.0), 25.0, 1e-12);
  EXPECT_NEAR(lf::diameter_for_f_number(2.0, fx, width, 1000.0), 0.025, 1e-12);  // metres
  EXPECT_NEAR(lf::full_frame_f_number(25.0, fx, width), 2.0, 1e-12);
  for (const double n : {1.4, 5.6, 22.0})
    EXPECT_NEAR(
        lf::full_frame_f_number(lf::diameter_for_f_number(n, fx, width, 10.0) * 10.0, fx, width), n,
        1e-12);
  EXPECT_EQ(lf::millimetres_per_unit("stanford-parallax-unit"), 0.0);
  EXPECT_EQ(lf::diameter_for_f_number(2.0, fx, width, 0.0), 0.0);
  EXPECT_EQ(lf::aperture_scale_for(lf::aperture_diameter(2.5, 0.3), 0.3), 2.5);
  EXPECT_EQ(lf::aperture_scale_for(0.1, 0.3), 1.0) << "never narrower than the tent";
}

// 10-90 % width (pixels) of the mean radial profile of a bright disc's
// edge in `img`: centre c, radius r pixels, profile over r +- span.
double edge_width(const cv::Mat& img, cv::Point2d c, double r, double span) {
  cv::Mat grey;
  cv::cvtColor(img, grey, cv::COLOR_RGBA2GRAY);
  std::vector<double> prof;
  const double step = 0.25;
  for (double rr = r - span; rr <= r + span; rr += step) {
    double sum = 0;
    int n = 0;
    for (int a = 0; a < 720; ++a) {
      const double t = a * CV_PI / 360;
      cv::Mat px;
      cv::getRectSubPix(grey, {1, 1}, cv::Point2f(c.x + rr * std::cos(t), c.y + rr * std::sin(t)),
                        px, CV_32F);
      sum += px.at<float>(0, 0), ++n;
    }
    prof.push_back(sum / n);
  }
  const double hi = prof.front(), lo = prof.back();  // the disc inside, the background out
  auto cross = [&](double f) {
    const double level = lo + f * (hi - lo);
    for (size_t i = 1; i < prof.size(); ++i)
      if (prof[i] <= level && prof[i - 1] > level)
        return (i - 1 + (prof[i - 1] - level) / (prof[i - 1] - prof[i])) * step;
    return prof.size() * step;
  };
  return cross(0.1) - cross(0.9);
}

TEST(Render, AWiderApertureBlursOffPlaneEdgesAndKeepsThePlaneSharp) {
  // A white disc at depth 6 in front of the textured plane at depth 10, the
  // view focused on the plane from the camera plane (constant weights: the
  // output is the aperture's weighted sum of shifted images). The disc's
  // edge blurs over fx * D * |1/6 - 1/10| pixels, D = 2 * spacing * scale
  // (lf::aperture_diameter); the plane stays as sharp as with the tent.
  const double spacing = 0.2, near = 6, disc_r = 1.0;
  const lf::Rig rig = lf::synthetic_grid_rig(9, 9, spacing, 200, 150, 50);
  // The scene, and the disc alone on black (its edge profile, free of the
  // plane's texture).
  std::vector<cv::Mat> images, disc_only;
  for (const auto& cam : rig.cameras) {
    cv::Mat im = lf::render_textured_plane(cam, kDepth, kPeriod);
    cv::Mat disc(im.size(), CV_8UC4, cv::Scalar(0, 0, 0, 255));
    for (int y = 0; y < im.rows; ++y)
      for (int x = 0; x < im.cols; ++x) {
        const auto d = cam.unproject({double(x), double(y)});
        if (!d || (*d)[2] <= 0) continue;
        const cv::Vec3d P = cam.center() + *d * ((near - cam.center()[2]) / (*d)[2]);
        if (std::hypot(P[0], P[1]) >= disc_r) continue;
        im.at<cv::Vec4b>(y, x) = disc.at<cv::Vec4b>(y, x) = {255, 255, 255, 255};
      }
    images.push_back(im);
    disc_only.push_back(disc);
  }
  lf::ViewRequest req = view_at({0.03, 0.01, 0}, {0.03, 0.01, kDepth});
  const double fx = req.view.focal_px();
  const cv::Point2d centre(req.view.width / 2.0 - 0.5 - fx * 0.03 / near,
                           req.view.height / 2.0 - 0.5 - fx * 0.01 / near);
  const double radius = fx * disc_r / near;  // the disc's image, pixels
  const cv::Mat truth = lf::render_textured_plane(camera_of(req.view), kDepth, kPeriod);
  cv::Mat far_mask(req.view.height, req.view.width, CV_8U, cv::Scalar(0));
  double tent_width = 0, tent_psnr = 0;
  for (const double k : {1.0, 3.0}) {
    req.aperture_scale = k;
    lf::RenderStats st;
    const cv::Mat out = lf::render_view(rig, images, req, &st);
    const double blur = fx * lf::aperture_diameter(k, spacing) * (1 / near - 1 / kDepth);
    const double width =
        edge_width(lf::render_view(rig, disc_only, req), centre, radius, 0.45 * radius);
    // The plane: pixels clear of the widest blur of the disc's edge.
    far_mask.setTo(0);
    cv::circle(far_mask, centre,
               radius + 0.6 * fx * lf::aperture_diameter(3, spacing) * (1 / near - 1 / kDepth) + 3,
               255, -1);
    cv::Mat plane_out = out.clone(), plane_truth = truth.clone();
    plane_out.setTo(0, far_mask), plane_truth.setTo(0, far_mask);
    const double p = covered_psnr(plane_out, plane_truth);
    std::printf(
        "aperture scale %.0f: %d cameras, %zu fragment px; edge 10-90 %% %.1f px (blur %.1f px); "
        "plane %.1f dB\n",
        k, st.contributing, st.fragment_pixels, width, blur, p);
    if (k == 1) {
      tent_width = width, tent_psnr = p;
      continue;
    }
    EXPECT_GT(width, 2 * tent_width) << "the off-plane edge blurs";
    EXPECT_GT(width, 0.25 * blur);
    EXPECT_LT(width, 0.75 * blur);
    EXPECT_GT(p, tent_psnr - 1.0) << "the plane stays sharp";
    EXPECT_GT(p, 38.0);
  }
}

// Bicubic sampling (lf/geometry/view.h Sampling) against the analytic image of the
// focal plane: closer than bilinear where the texture is fine (a period of
// a few camera pixels), and a flat image stays flat (its taps sum to 1).
TEST(Render, BicubicSamplingIsCloserToTheTruth) {
  const lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.5, 240, 180, 50);
  const double period = 0.25;  // about 5 camera pixels at the plane
  std::vector<cv::Mat> images;
  for (const auto& c : rig.cameras) images.push_back(lf::render_textured_plane(c, kDepth, period));
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<double> u(-1, 1);
  double gain = 0, min_gain = 1e9;
  const int views = 5;
  for (int k = 0; k < views; ++k) {
    auto req = view_at({0.6 * u(rng), 0.6 * u(rng), 0.5 * u(rng)}, {u(rng), u(rng), kDepth});
    const cv::Mat truth = lf::render_textured_plane(camera_of(req.view), kDepth, period);
    const double bilinear = covered_psnr(lf::render_view(rig, images, req), truth);
    req.sampling = lf::Sampling::kBicubic;
    const double bicubic = covered_psnr(lf::render_view(rig, images, req), truth);
    std::printf("view %d: bilinear %.2f dB, bicubic %.2f dB\n", k, bilinear, bicubic);
    gain += (bicubic - bilinear) / views;
    min_gain = std::min(min_gain, bicubic - bilinear);
  }
  std::printf("bicubic over bilinear: mean %+.2f dB, least %+.2f dB\n", gain, min_gain);
  EXPECT_GT(min_gain, 0.5);
  // A flat grey image: every covered pixel that grey, up to the 8-bit
  // rounding of premultiplied fragments (as bilinear).
  std::vector<cv::Mat> flat(rig.cameras.size(),
                            cv::Mat(180, 240, CV_8UC4, cv::Scalar(77, 77, 77, 255)));
  auto req = view_at({0.1, 0.2, -0.5}, {0, 0, kDepth});
  req.sampling = lf::Sampling::kBicubic;
  const cv::Mat out = lf::render_view(rig, flat, req);
  int off = 0;
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      const auto p = out.at<cv::Vec4b>(y, x);
      off += p[3] == 255 &&
             (std::abs(p[0] - 77) > 1 || std::abs(p[1] - 77) > 1 || std::abs(p[2] - 77) > 1);
    }
  EXPECT_EQ(off, 0);
}

TEST(Render, LensDistortionIsAppliedToSamplingCoordinates) {
  lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.5, 240, 180, 50, 1.0, 8);
  for (auto& c : rig.cameras) c.intrinsics.k1 = -0.2, c.intrinsics.k2 = 0.05;
  rig.finalize();
  const auto images = images_of(rig);  // distorted images
  const auto req = view_at({0.1, -0.2, 0.0}, {0.3, 0.2, kDepth});
  const cv::Mat truth = lf::render_textured_plane(camera_of(req.view), kDepth, kPeriod);
  const double with = covered_psnr(lf::render_view(rig, images, req), truth);
  lf::Rig ignorant = rig;  // same images, distortion ignored
  for (auto& c : ignorant.cameras) c.intrinsics.k1 = c.intrinsics.k2 = 0;
  ignorant.finalize();
  const double without = covered_psnr(lf::render_view(ignorant, images, req), truth);
  EXPECT_GT(with, 38.0);
  EXPECT_LT(without, with - 10.0);
}

TEST(Render, AccumulatedWeightIsFullWhereverTheSurfaceIsSeen) {
  const lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.5, 240, 180, 50);
  const auto images = images_of(rig);
  const auto req = view_at({0.2, 0.1, -1.0}, {0.0, 0.0, kDepth});
  const lf::ViewGeometry g(rig, req);
  lf::Compositor comp;
  comp.reset(req.view.width, req.view.height);
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    lf::Fragment f;
    lf::render_fragment(lf::plan_fragment(g, static_cast<int>(i)), rig.cameras[i], images[i], f);
    comp.add(f);
  }
  int seen = 0, worst = 0;
  for (int y = 0; y < req.view.height; ++y)
    for (int x = 0; x < req.view.width; ++x) {
      if (g.locate(x, y).simplex < 0) {
        EXPECT_EQ(comp.weight_at(x, y), 0u);
        continue;
      }
      // Every camera sees this plane fully here: 3 premultiplied alphas add
      // to 255 up to rounding (one 8-bit rounding per fragment).
      worst = std::max(worst, std::abs(static_cast<int>(comp.weight_at(x, y)) - 255));
      ++seen;
    }
  EXPECT_GT(seen, 1000);
  EXPECT_LE(worst, 2);
}

TEST(Render, MissingFragmentDegradesGracefully) {
  const lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.5, 240, 180, 50);
  const auto images = images_of(rig);
  const auto req = view_at({0.1, 0.1, -1.0}, {0.0, 0.0, kDepth});
  const lf::ViewGeometry g(rig, req);
  std::vector<lf::Fragment> frags(rig.cameras.size());
  for (size_t i = 0; i < rig.cameras.size(); ++i)
    lf::render_fragment(lf::plan_fragment(g, static_cast<int>(i)), rig.cameras[i], images[i],
                        frags[i]);
  auto composite = [&](int skip) {
    lf::Compositor c;
    c.reset(req.view.width, req.view.height);
    for (size_t i = 0; i < frags.size(); ++i)
      if (static_cast<int>(i) != skip) c.add(frags[i]);
    cv::Mat out;
    c.resolve(out);
    return out;
  };
  const cv::Mat full = composite(-1);
  // Drop the camera with the largest fragment.
  int big = 0;
  for (size_t i = 0; i < frags.size(); ++i)
    if (frags[i].pixel_count() > frags[big].pixel_count()) big = static_cast<int>(i);
  const cv::Mat degraded = composite(big);
  double diff = 0;
  size_t n = 0, holes = 0;
  for (int y = 0; y < full.rows; ++y)
    for (int x = 0; x < full.cols; ++x) {
      const auto a = full.at<cv::Vec4b>(y, x), b = degraded.at<cv::Vec4b>(y, x);
      if (a[3] != 255) continue;
      if (b[3] != 255) {
        ++holes;  // only where the dropped camera was the sole contributor
        continue;
      }
      for (int c = 0; c < 3; ++c) diff += std::abs(a[c] - b[c]);
      n += 3;
    }
  ASSERT_GT(n, 0u);
  // Renormalised, not darkened: the remaining cameras see the same plane.
  EXPECT_LT(diff / n, 1.5);
  EXPECT_LT(holes, n / 3 / 50);
}

// A lost camera with the eye on it: the tent weights only that camera
// there, so its loss leaves a hole (the compositor has nothing to
// renormalise); an aperture of 2 tents covers it with its neighbours'
// fragments, on the focal plane as exactly as the full rig; so do ULR
// weights.
TEST(Render, AWiderApertureCoversALostCamera) {
  const lf::Rig rig = lf::synthetic_grid_rig(5, 5, 0.5, 240, 180, 50);
  const auto images = images_of(rig);
  const int lost = 12;  // the centre camera
  const cv::Vec3d at = rig.cameras[lost].center();
  const lf::ViewRequest view = view_at(at, at + cv::Vec3d(0, 0, kDepth));
  const cv::Mat truth = lf::render_textured_plane(camera_of(view.view), kDepth, kPeriod);
  // The view composited without the lost camera: its coverage and PSNR.
  auto without_lost = [&](const lf::ViewRequest& req, const char* what) {
    const lf::ViewGeometry g(rig, req);
    lf::Compositor c;
    c.reset(req.view.width, req.view.height);
    for (size_t i = 0; i < rig.cameras.size(); ++i) {
      if (static_cast<int>(i) == lost) continue;
      lf::Fragment f;
      lf::render_fragment(lf::plan_fragment(g, static_cast<int>(i)), rig.cameras[i], images[i], f);
      c.add(f);
    }
    cv::Mat out;
    c.resolve(out);
    std::pair<double, double> r;  // coverage, PSNR
    r.second = covered_psnr(out, truth, &r.first);
    std::printf("%s without the camera under the eye: %.1f %% covered, %.1f dB\n", what,
                100 * r.first, r.second);
    return r;
  };
  lf::ViewRequest req = view;
  const auto tent = without_lost(req, "the tent");
  EXPECT_LT(tent.first, 0.05) << "the tent leaves a hole";
  req.aperture_scale = 2;
  const auto wide = without_lost(req, "aperture scale 2");
  EXPECT_EQ(wide.first, 1.0) << "no hole";
  EXPECT_GT(wide.second, 40.0);
  // ULR weights (k = 4) cover it too: its neighbours blend wherever it did.
  req.aperture_scale = 1;
  req.aperture = lf::Aperture::kUlr;
  req.ulr_cameras = 4;
  const auto ulr = without_lost(req, "ULR k = 4");
  EXPECT_EQ(ulr.first, 1.0) << "no hole";
  // Where the lost camera dominated, the rest carried small weights, so
  // their 8-bit premultiplied colour is coarse there (49.4 dB with it).
  EXPECT_GT(ulr.second, 25.0);
}

// Every vector kernel that this CPU and build have against the scalar
// reference, byte for byte, with and without lens distortion, on views whose
// fragments have runs of every length (so the vector loops' tails run too).
TEST(Render, VectorKernelsAreBitIdenticalToScalar) {
  std::vector<lf::Kernel> kernels;
  for (lf::Kernel k : {lf::Kernel::kSse2, lf::Kernel::kAvx2, lf::Kernel::kAvx512})
    if (lf::kernel_available(k)) kernels.push_back(k);
#if defined(__x86_64__)
  // A SIMD build on x86-64 has SSE2, and AVX2 and AVX-512 exactly where the
  // CPU does.
  if (lf::simd_available()) {
    EXPECT_EQ(lf::kernel_available(lf::Kernel::kAvx2), __builtin_cpu_supports("avx2") != 0);
    EXPECT_EQ(lf::kernel_available(lf::Kernel::kAvx512),
              __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                  __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512vl"));
  }
#endif
  EXPECT_TRUE(lf::kernel_available(lf::best_kernel()));
  // AVX-512's bilinear gather reads its taps either way (lf::TapLoads): both.
  struct Way {
    lf::Kernel kernel;
    lf::TapLoads taps;
  };
  std::vector<Way> ways;
  for (lf::Kernel k : kernels)
    if (k == lf::Kernel::kAvx512)
      ways.push_back({k, lf::TapLoads::kGather}), ways.push_back({k, lf::TapLoads::kLoads});
    else
      ways.push_back({k, lf::TapLoads::kAuto});
  for (const auto& [kernel, taps] : ways)
    for (bool distort : {false, true})
      for (const lf::Sampling sampling : {lf::Sampling::kBilinear, lf::Sampling::kBicubic}) {
        lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 240, 180, 50, 2.0, 6);
        if (distort)
          for (auto& c : rig.cameras) c.intrinsics.k1 = -0.2, c.intrinsics.k2 = 0.05;
        rig.finalize();
        auto images = images_of(rig);
        if (sampling == lf::Sampling::kBicubic) {
          // Noise too: the cubic's negative lobes overshoot and are clamped.
          cv::RNG rng(7);
          for (auto& im : images) {
            cv::Mat noise(im.size(), CV_8UC4);
            rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
            cv::addWeighted(im, 0.5, noise, 0.5, 0, im);
            im.reshape(1, im.rows * im.cols).col(3).setTo(255);
          }
        }
        size_t compared = 0;
        for (auto req : {view_at({0.3, -0.1, -0.8}, {0.0, 0.2, kDepth}),
                         view_at({-0.45, 0.37, 0.6}, {0.1, -0.1, kDepth * 0.7})}) {
          req.sampling = sampling;
          const lf::ViewGeometry g(rig, req);
          for (size_t i = 0; i < rig.cameras.size(); ++i) {
            const auto plan = lf::plan_fragment(g, static_cast<int>(i));
            lf::Fragment a, b;
            lf::set_tap_loads(taps);
            lf::render_fragment(plan, rig.cameras[i], images[i], a, kernel);
            lf::set_tap_loads(lf::TapLoads::kAuto);
            lf::render_fragment(plan, rig.cameras[i], images[i], b, lf::Kernel::kScalar);
            EXPECT_EQ(a.pixels, b.pixels)
                << lf::kernel_name(kernel) << " (taps by " << lf::tap_loads_name(taps)
                << "), camera " << i << (distort ? " (distorted)" : "")
                << (sampling == lf::Sampling::kBicubic ? " bicubic" : " bilinear");
            compared += a.pixel_count();
          }
        }
        EXPECT_GT(compared, 40000u) << lf::kernel_name(kernel);
      }
}

// The AVX-512 gather's way of reading taps: timed once (never kAuto after),
// the same choice every time it is asked, overridden and given back by
// set_tap_loads().
TEST(Render, TapLoadsAreTimedOnceAndCanBeChosen) {
  const lf::TapLoads timed = lf::tap_loads();
  EXPECT_NE(timed, lf::TapLoads::kAuto);
  if (!lf::kernel_available(lf::Kernel::kAvx512)) EXPECT_EQ(timed, lf::TapLoads::kLoads);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(lf::tap_loads(), timed);
  for (lf::TapLoads t : {lf::TapLoads::kGather, lf::TapLoads::kLoads}) {
    lf::set_tap_loads(t);
    EXPECT_EQ(lf::tap_loads(), t);
  }
  lf::set_tap_loads(lf::TapLoads::kAuto);
  EXPECT_EQ(lf::tap_loads(), timed);
  EXPECT_STREQ(lf::tap_loads_name(lf::TapLoads::kGather), "gather instruction");
  EXPECT_STREQ(lf::tap_loads_name(lf::TapLoads::kLoads), "scalar loads");
  std::printf("AVX-512 taps on this CPU: by %s\n", lf::tap_loads_name(timed));
}

// A kernel that this CPU or build lacks is refused, not run.
TEST(Render, KernelsRunOnlyWhereAvailable) {
  const lf::Rig rig = lf::synthetic_grid_rig(2, 2, 0.5, 64, 48, 50);
  const lf::ViewGeometry g(rig, view_at({0, 0, 0}, {0, 0, kDepth}));
  int cam = 0;
  while (cam < 3 && lf::plan_fragment(g, cam).empty()) ++cam;
  const auto plan = lf::plan_fragment(g, cam);
  ASSERT_FALSE(plan.empty());
  const cv::Mat image(48, 64, CV_8UC4, cv::Scalar::all(90));
  for (lf::Kernel k :
       {lf::Kernel::kScalar, lf::Kernel::kSse2, lf::Kernel::kAvx2, lf::Kernel::kAvx512}) {
    lf::Fragment f;
    if (lf::kernel_available(k)) {
      EXPECT_NO_THROW(lf::render_fragment(plan, rig.cameras[cam], image, f, k));
      EXPECT_GT(f.pixel_count(), 0u);
    } else {
      EXPECT_THROW(lf::render_fragment(plan, rig.cameras[cam], image, f, k), std::invalid_argument);
    }
  }
}

// Rendering in place (describe_fragment + render_pixels, as lffragment
// renders raw fragments straight into its output buffer) writes every byte
// of the caller's memory, whatever was there: the same pixels as
// render_fragment(), and zeros in a row's gaps between runs (made here by
// cutting runs in two, since a planar view's rows seldom have gaps).
TEST(Render, InPlaceRenderingWritesEveryByte) {
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 240, 180, 50, 2.0, 6);
  const auto images = images_of(rig);
  const lf::ViewGeometry g(rig, view_at({0.3, -0.1, -0.8}, {0.0, 0.2, kDepth}));
  size_t compared = 0, gap_pixels = 0;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const auto plan = lf::plan_fragment(g, static_cast<int>(i));
    lf::Fragment ref;
    lf::render_fragment(plan, rig.cameras[i], images[i], ref);
    lf::Fragment geo;
    geo.pixels.assign(12, 7);  // cleared by describe_fragment
    lf::describe_fragment(plan, geo);
    EXPECT_EQ(geo.rect, ref.rect);
    EXPECT_EQ(geo.spans, ref.spans);
    EXPECT_TRUE(geo.pixels.empty());
    std::vector<uint8_t> mem(4 * plan.pixel_count(), 0xcd);
    lf::render_pixels(plan, rig.cameras[i], images[i], mem.data());
    EXPECT_EQ(mem, ref.pixels) << "camera " << i;
    compared += plan.pixel_count();

    // Gaps: every run of 12 or more pixels loses 5 pixels in its middle.
    lf::FragmentPlan cut = plan;
    cut.runs.clear();
    std::vector<std::pair<int, int>> gaps;  // (row index, x) of removed pixels
    for (const lf::Run& r : plan.runs) {
      if (r.x1 - r.x0 < 12) {
        cut.runs.push_back(r);
        continue;
      }
      const int m = (r.x0 + r.x1) / 2;
      lf::Run a = r, b = r;
      a.x1 = m;
      b.x0 = m + 5;
      cut.runs.push_back(a);
      cut.runs.push_back(b);
      for (int x = m; x < m + 5; ++x) gaps.emplace_back(r.y - plan.rect.y, x);
    }
    std::vector<uint8_t> holed(mem.size(), 0xcd);
    lf::render_pixels(cut, rig.cameras[i], images[i], holed.data());
    std::vector<uint8_t> expect = ref.pixels;
    std::vector<size_t> row_start(plan.row_spans.size() + 1, 0);
    for (size_t r = 0; r < plan.row_spans.size(); ++r)
      row_start[r + 1] = row_start[r] + 4 * (plan.row_spans[r][1] - plan.row_spans[r][0]);
    for (const auto& [r, x] : gaps)
      std::fill_n(expect.begin() + row_start[r] + 4 * (x - plan.row_spans[r][0]), 4, 0);
    EXPECT_EQ(holed, expect) << "camera " << i;
    gap_pixels += gaps.size();

    // Row by row in pieces (render_rows, as the fused compositor draws a
    // band at a time): the same bytes, gaps included, whatever the cuts.
    const int rows = static_cast<int>(plan.row_spans.size());
    for (int piece : {1, 7, 32}) {
      std::vector<uint8_t> pieces(holed.size(), 0xcd);
      for (int r0 = 0; r0 < rows; r0 += piece) {
        const int r1 = std::min(rows, r0 + piece);
        lf::render_rows(cut, rig.cameras[i], images[i], r0, r1, pieces.data() + row_start[r0]);
      }
      EXPECT_EQ(pieces, expect) << "camera " << i << ", " << piece << " rows at a time";
    }
    uint8_t none = 0;
    EXPECT_THROW(lf::render_rows(plan, rig.cameras[i], images[i], 0, rows + 1, &none),
                 std::invalid_argument);
    EXPECT_THROW(lf::render_rows(plan, rig.cameras[i], images[i], 2, 1, &none),
                 std::invalid_argument);
    EXPECT_NO_THROW(lf::render_rows(plan, rig.cameras[i], images[i], rows, rows, &none));

    // Into an image of the rect (row_bytes, as a JPEG sender draws): each
    // row's span pixels where the rect's image has them, the same bytes,
    // and nothing outside the spans written; in pieces too, with a row
    // longer than the rect's.
    if (rows == 0) continue;
    const int w = plan.rect.width;
    for (const size_t row_bytes : {4 * static_cast<size_t>(w), 4 * static_cast<size_t>(w) + 12}) {
      for (int piece : {rows, 7}) {
        std::vector<uint8_t> image(row_bytes * rows, 0xcd);
        for (int r0 = 0; r0 < rows; r0 += piece)
          lf::render_rows(cut, rig.cameras[i], images[i], r0, std::min(rows, r0 + piece),
                          image.data() + r0 * row_bytes, lf::Kernel::kBest, row_bytes);
        std::vector<uint8_t> want(image.size(), 0xcd);
        for (int r = 0; r < rows; ++r)
          std::copy(expect.begin() + row_start[r], expect.begin() + row_start[r + 1],
                    want.begin() + r * row_bytes + 4 * (plan.row_spans[r][0] - plan.rect.x));
        EXPECT_EQ(image, want) << "camera " << i << ", " << row_bytes << " bytes a row, " << piece
                               << " rows at a time";
      }
    }
    EXPECT_THROW(lf::render_rows(plan, rig.cameras[i], images[i], 0, rows, &none, lf::Kernel::kBest,
                                 4 * static_cast<size_t>(w) - 1),
                 std::invalid_argument);
  }
  EXPECT_GT(compared, 20000u);
  EXPECT_GT(gap_pixels, 500u);
}

// The compositor's normalisation against the formula it documents, computed
// here independently from the sums of random fragments (full frames with
// random spans, random premultiplied colours and weights, and pixels that no
// fragment reaches): every pixel, every channel, exactly.
TEST(Composite, ResolveMatchesTheFormulaEverywhere) {
  const int W = 37, H = 23;  // odd sizes: no vector loop ends evenly
  cv::RNG rng(12345);
  std::vector<uint32_t> sum(static_cast<size_t>(W) * H * 4, 0);
  std::vector<lf::Fragment> frags;
  for (int f = 0; f < 6; ++f) {
    lf::Fragment fr;
    fr.out_width = W, fr.out_height = H;
    fr.rect = {0, 0, W, H};
    // The last one a partial sum: its values are added << weight_shift.
    if (f == 5) fr.cameras = 4, fr.weight_shift = 2;
    for (int y = 0; y < H; ++y) {
      const int b = rng.uniform(0, W), e = rng.uniform(b, W + 1);
      fr.spans.push_back({static_cast<uint16_t>(b), static_cast<uint16_t>(e)});
      for (int x = b; x < e; ++x) {
        const int w = rng.uniform(0, 256);
        for (int ch = 0; ch < 4; ++ch) {
          const int v = ch == 3 ? w : rng.uniform(0, w + 1);  // premultiplied: colour <= weight
          fr.pixels.push_back(static_cast<uint8_t>(v));
          sum[(static_cast<size_t>(y) * W + x) * 4 + ch] += static_cast<uint32_t>(v)
                                                            << fr.weight_shift;
        }
      }
    }
    frags.push_back(fr);
  }
  // Every kernel this CPU has: the same sums and the same bytes.
  int kernels = 0;
  for (const lf::Kernel kernel :
       {lf::Kernel::kScalar, lf::Kernel::kSse2, lf::Kernel::kAvx2, lf::Kernel::kAvx512}) {
    lf::Compositor comp;
    if (!lf::kernel_available(kernel)) {
      EXPECT_THROW(comp.set_kernel(kernel), std::invalid_argument);
      continue;
    }
    ++kernels;
    comp.set_kernel(kernel);
    EXPECT_EQ(comp.kernel(), kernel);
    comp.reset(W, H);
    for (const lf::Fragment& fr : frags) comp.add(fr);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        ASSERT_EQ(std::vector<uint32_t>(comp.sums_at(x, y), comp.sums_at(x, y) + 4),
                  std::vector<uint32_t>(&sum[(static_cast<size_t>(y) * W + x) * 4],
                                        &sum[(static_cast<size_t>(y) * W + x) * 4] + 4))
            << lf::kernel_name(kernel) << " " << x << "," << y;
    cv::Mat out;
    comp.resolve(out);
    size_t empty = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const uint32_t* a = &sum[(static_cast<size_t>(y) * W + x) * 4];
        const cv::Vec4b o = out.at<cv::Vec4b>(y, x);
        if (a[3] == 0) {
          ++empty;
          EXPECT_EQ(o, cv::Vec4b(0, 0, 0, 0)) << lf::kernel_name(kernel) << " " << x << "," << y;
          continue;
        }
        const float s = 255.0f / static_cast<float>(a[3]);
        for (int ch = 0; ch < 3; ++ch)
          EXPECT_EQ(o[ch], static_cast<uint8_t>(std::min(255.0f, a[ch] * s + 0.5f)))
              << lf::kernel_name(kernel) << " " << x << "," << y << " channel " << ch;
        EXPECT_EQ(o[3], 255);
      }
    EXPECT_GT(empty, 0u);
    EXPECT_LT(empty, static_cast<size_t>(W) * H / 2);
  }
  EXPECT_GE(kernels, 1);
}

// The fused, banded composite() against reset + add + resolve: the same
// frame and sums bit for bit, on 1, 2 and 4 threads, with fragments that
// cross band borders, start and end inside bands, borrowed pixels, an empty
// fragment, and refused ones (wrong frame size, no pixels) left out and
// reported by index.
TEST(Composite, FusedCompositeEqualsAddAndResolve) {
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 240, 180, 50, 2.0, 6);
  const auto images = images_of(rig);
  const lf::ViewGeometry g(rig, view_at({-0.2, 0.15, -0.5}, {0.1, 0.0, kDepth}));
  std::vector<lf::Fragment> frags(rig.cameras.size());
  for (size_t i = 0; i < frags.size(); ++i)
    lf::render_fragment(lf::plan_fragment(g, static_cast<int>(i)), rig.cameras[i], images[i],
                        frags[i]);
  lf::Fragment other = frags[4];  // for another frame size
  other.out_width += 2;
  lf::Fragment empty;
  empty.out_width = 200, empty.out_height = 150;
  std::vector<lf::FragmentPixels> in;
  for (const auto& f : frags) in.push_back({&f, f.pixels.data()});
  in.insert(in.begin() + 2, {&other, other.pixels.data()});
  in.push_back({&empty, nullptr});
  in.push_back({&frags[1], nullptr});  // pixels missing
  lf::Compositor ref;
  ref.reset(200, 150);
  for (const auto& f : frags) ref.add(f);
  cv::Mat want;
  ref.resolve(want);
  size_t covered = 0;
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < 200; ++x) covered += ref.weight_at(x, y) > 0;
  EXPECT_GT(covered, 200u * 150u / 2);
  const int saved = cv::getNumThreads();
  for (int threads : {1, 2, 4}) {
    cv::setNumThreads(threads);
    lf::Compositor comp;
    cv::Mat got(7, 7, CV_8UC4, cv::Scalar::all(99));  // reallocated
    const auto refused = comp.composite(200, 150, in, got);
    ASSERT_EQ(refused.size(), 2u);
    EXPECT_EQ(refused[0].first, 2u);
    EXPECT_NE(refused[0].second.find("frame"), std::string::npos) << refused[0].second;
    EXPECT_EQ(refused[1].first, in.size() - 1);
    EXPECT_NE(refused[1].second.find("no pixels"), std::string::npos) << refused[1].second;
    EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0) << threads << " threads";
    // Its sums lived band by band in the threads' buffers: none to read or
    // add to until a reset().
    EXPECT_THROW(comp.weight_at(0, 0), std::logic_error);
    EXPECT_THROW(comp.add(frags[0]), std::logic_error);
    EXPECT_THROW(comp.resolve(got), std::logic_error);
    // Kept on request (LayerCompositor reads layer 0's): the sums of add().
    comp.set_keep_sums(true);
    comp.composite(200, 150, in, got);
    EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0) << threads << " threads";
    for (int y = 0; y < 150; y += 7)
      for (int x = 0; x < 200; x += 3) ASSERT_EQ(comp.weight_at(x, y), ref.weight_at(x, y));
    // Each row's sums handed to `row_summed` once, complete (add()'s, bit
    // for bit), kept or not (LayerCompositor takes layer 0's variance there).
    for (bool keep : {false, true}) {
      comp.set_keep_sums(keep);
      std::vector<std::atomic<int>> calls(150);
      std::atomic<int> wrong{0};
      const lf::Compositor::RowSummed seen = [&](int y, const uint32_t* sums) {
        ++calls[y];
        if (std::memcmp(sums, ref.sums_at(0, y), 200 * 16) != 0) ++wrong;
      };
      comp.composite(200, 150, in, {}, got, nullptr, &seen);
      EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0) << threads << " threads, kept " << keep;
      EXPECT_EQ(wrong.load(), 0) << threads << " threads, kept " << keep;
      for (int y = 0; y < 150; ++y) ASSERT_EQ(calls[y].load(), 1) << y;
    }
    // Or only some runs of pixels (LayerCompositor keeps layer 0's where
    // layer 1 reaches): those are add()'s sums, bit for bit, and nothing
    // else is written (a mark set everywhere stays); the frame is the same.
    const lf::Compositor::Runs runs = {{{0, 8}, {40, 72}}, {}, {{192, 200}}, {{0, 200}}};
    for (int y = 0; y < 150; ++y)  // a mark where no run is
      for (int x = 0; x < 200; ++x) const_cast<uint32_t*>(comp.sums_at(x, y))[3] = 7777;
    comp.set_kept_runs(&runs, 40);  // rows of 40: 4 entries cover 150 rows
    comp.composite(200, 150, in, got);
    EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0) << threads << " threads";
    int kept = 0;
    for (int y = 0; y < 150; ++y)
      for (int x = 0; x < 200; ++x) {
        bool in_run = false;
        for (const auto& [x0, x1] : runs[y / 40]) in_run |= x >= x0 && x < x1;
        if (!in_run) {
          ASSERT_EQ(comp.weight_at(x, y), 7777u) << x << "," << y;
          continue;
        }
        ++kept;
        ASSERT_EQ(std::memcmp(comp.sums_at(x, y), ref.sums_at(x, y), 16), 0) << x << "," << y;
      }
    EXPECT_EQ(kept, 40 * 40 + 40 * 8 + 30 * 200);
    // Runs that do not cover the rows, or leave the frame: refused.
    const lf::Compositor::Runs short_runs(3), wide = {{{190, 201}}, {}, {}, {}};
    comp.set_kept_runs(&short_runs, 40);
    EXPECT_THROW(comp.composite(200, 150, in, got), std::invalid_argument);
    comp.set_kept_runs(&wide, 40);
    EXPECT_THROW(comp.composite(200, 150, in, got), std::invalid_argument);
    comp.set_keep_sums(false);
    // Again into the same compositor and frame: nothing left from the last one.
    const std::vector<lf::FragmentPixels> two(in.begin(), in.begin() + 2);
    lf::Compositor ref2;
    ref2.reset(200, 150);
    ref2.add(frags[0]);
    ref2.add(frags[1]);
    cv::Mat want2;
    ref2.resolve(want2);
    EXPECT_TRUE(comp.composite(200, 150, two, got).empty());
    EXPECT_EQ(cv::norm(got, want2, cv::NORM_INF), 0) << threads << " threads";
  }
  cv::setNumThreads(saved);
  lf::Compositor c;
  cv::Mat out;
  EXPECT_THROW(c.composite(0, 10, in, out), std::invalid_argument);
}

// Render and composite fused (Compositor::composite with drawings: each
// band draws its rows of the cameras' fragments straight into its sums, as
// lfcompositor does with lffragment defer=true): the frame of the rendered
// fragments, bit for bit, with lens distortion and bicubic sampling, any
// mix of drawn and rendered fragments and any number of threads; drawings
// that cannot be drawn are refused by index, the rest still composited.
TEST(Composite, DrawingsComposeAsRenderedFragments) {
  lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 240, 180, 50, 2.0, 6);
  for (auto& c : rig.cameras) c.intrinsics.k1 = -0.1, c.intrinsics.k2 = 0.02;
  rig.finalize();
  const auto images = images_of(rig);
  const int saved = cv::getNumThreads();
  for (const lf::Sampling sampling : {lf::Sampling::kBilinear, lf::Sampling::kBicubic}) {
    lf::ViewRequest req = view_at({-0.2, 0.15, -0.5}, {0.1, 0.0, kDepth});
    req.sampling = sampling;
    const lf::ViewGeometry g(rig, req);
    std::vector<lf::FragmentPlan> plans;
    std::vector<lf::Fragment> frags(rig.cameras.size());
    for (size_t i = 0; i < frags.size(); ++i) {
      plans.push_back(lf::plan_fragment(g, static_cast<int>(i)));
      lf::render_fragment(plans[i], rig.cameras[i], images[i], frags[i]);
    }
    std::vector<lf::FragmentPixels> all;
    for (const auto& f : frags) all.push_back({&f, f.pixels.data()});
    lf::Compositor ref;
    cv::Mat want;
    ASSERT_TRUE(ref.composite(200, 150, all, want).empty());
    size_t covered = 0;  // alpha 255 where weight arrived, else 0
    for (int y = 0; y < 150; ++y)
      for (int x = 0; x < 200; ++x) covered += want.at<cv::Vec4b>(y, x)[3] == 255;
    EXPECT_GT(covered, 200u * 150u / 2);
    for (int threads : {1, 2, 4}) {
      cv::setNumThreads(threads);
      for (size_t drawn_from : {size_t{0}, size_t{4}, frags.size()}) {
        std::vector<lf::FragmentPixels> given(all.begin(), all.begin() + drawn_from);
        std::vector<lf::FragmentDrawing> drawings;
        for (size_t i = drawn_from; i < frags.size(); ++i)
          drawings.push_back({&plans[i], &rig.cameras[i], &images[i]});
        lf::Compositor comp;
        cv::Mat got(5, 5, CV_8UC4, cv::Scalar::all(99));
        EXPECT_TRUE(comp.composite(200, 150, given, drawings, got).empty());
        EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0)
            << threads << " threads, drawn from camera " << drawn_from;
      }
    }
    // Refusals: an image of the wrong size, no image, a plan for another
    // output size; the other drawings are still composited.
    size_t some = 0;
    while (plans[some].empty()) ++some;
    const cv::Mat small(10, 10, CV_8UC4, cv::Scalar::all(1));
    lf::FragmentPlan other = plans[some];
    other.out_width += 2;
    std::vector<lf::FragmentDrawing> drawings;
    for (size_t i = 0; i < frags.size(); ++i)
      drawings.push_back({&plans[i], &rig.cameras[i], &images[i]});
    drawings.push_back({&plans[some], &rig.cameras[some], &small});
    drawings.push_back({&plans[some], &rig.cameras[some], nullptr});
    drawings.push_back({&other, &rig.cameras[some], &images[some]});
    lf::Compositor comp;
    cv::Mat got;
    const auto refused = comp.composite(200, 150, {all[0]}, drawings, got);
    ASSERT_EQ(refused.size(), 3u);
    EXPECT_EQ(refused[0].first, 1 + frags.size());
    EXPECT_NE(refused[0].second.find("does not match"), std::string::npos) << refused[0].second;
    EXPECT_EQ(refused[1].first, 2 + frags.size());
    EXPECT_EQ(refused[2].first, 3 + frags.size());
    EXPECT_NE(refused[2].second.find("frame"), std::string::npos) << refused[2].second;
    // Camera 0 twice (given and drawn): its weight twice, the rest once.
    lf::Compositor twice;
    twice.reset(200, 150);
    for (const auto& f : frags) twice.add(f);
    twice.add(frags[0]);
    cv::Mat want2;
    twice.resolve(want2);
    EXPECT_EQ(cv::norm(got, want2, cv::NORM_INF), 0);
  }
  cv::setNumThreads(saved);
}

// Partial sums (issue 15's bandwidth point): a host's cameras summed into
// one fragment give the frame of their separate fragments (bit for bit
// where the sums fit 8 bits, within a level where they need a shift), in
// fewer pixels when the host's cameras are a contiguous block of the grid;
// the same comparison says what a dead host costs with blocks (a hole) and
// with interleaved hosts (none).
TEST(Composite, PartialSumsOfBlocksComposeTheSameFrame) {
  // The deployment's layout: 8x8 cameras, 4 hosts of 4x4 (net-host.sh).
  const lf::Rig rig = lf::synthetic_grid_rig(8, 8, 0.25, 240, 180, 50);
  const auto images = images_of(rig);
  const int kHosts = 4;
  auto block_of = [](int i) { return (i / 8) / 4 * 2 + (i % 8) / 4; };
  auto interleaved = [](int i) { return i % 4; };
  for (const double scale : {1.0, 3.0}) {
    lf::ViewRequest req = view_at({0.3, 0.2, -1.0}, {0.1, 0.0, kDepth});
    req.aperture_scale = scale;
    const lf::ViewGeometry g(rig, req);
    std::vector<lf::Fragment> frags(rig.cameras.size());
    size_t camera_pixels = 0;
    for (size_t i = 0; i < frags.size(); ++i) {
      lf::render_fragment(lf::plan_fragment(g, static_cast<int>(i)), rig.cameras[i], images[i],
                          frags[i]);
      camera_pixels += frags[i].pixel_count();
    }
    auto composite = [&](const std::vector<const lf::Fragment*>& fs) {
      std::vector<lf::FragmentPixels> in;
      for (const lf::Fragment* f : fs) in.push_back({f, f->pixels.data()});
      lf::Compositor c;
      cv::Mat out;
      c.composite(req.view.width, req.view.height, in, out);
      return out;
    };
    std::vector<const lf::Fragment*> all;
    for (const auto& f : frags) all.push_back(&f);
    const cv::Mat want = composite(all);
    // The sums per host, for both assignments.
    auto sums_of = [&](auto host_of) {
      std::vector<lf::Fragment> sums;
      for (int h = 0; h < kHosts; ++h) {
        std::vector<lf::FragmentPixels> in;
        for (size_t i = 0; i < frags.size(); ++i)
          if (host_of(static_cast<int>(i)) == h) in.push_back({&frags[i], frags[i].pixels.data()});
        sums.push_back(lf::sum_fragments(in));
        EXPECT_EQ(sums.back().cameras, 16);
        EXPECT_NO_THROW(lf::check_fragment(sums.back()));
      }
      return sums;
    };
    const auto blocks = sums_of(block_of), mixed = sums_of(interleaved);
    size_t block_pixels = 0, mixed_pixels = 0;
    int top_shift = 0;
    for (const auto& s : blocks)
      block_pixels += s.pixel_count(), top_shift = std::max<int>(top_shift, s.weight_shift);
    for (const auto& s : mixed) mixed_pixels += s.pixel_count();
    std::vector<const lf::Fragment*> b;
    for (const auto& s : blocks) b.push_back(&s);
    const cv::Mat got = composite(b);
    const double diff = cv::norm(got, want, cv::NORM_L1) / (got.total() * 3.0);  // alpha equal
    const double worst = cv::norm(got, want, cv::NORM_INF);
    const double psnr = covered_psnr(got, want);
    // Through the wire (version 2 header), raw: the same frame again.
    std::vector<lf::Fragment> wired;
    for (const auto& s : blocks) {
      const auto bytes = lf::serialize_fragment(s, lf::Encoding::kRaw);
      wired.push_back(lf::parse_fragment(bytes.data(), bytes.size()));
      EXPECT_EQ(wired.back().cameras, s.cameras);
      EXPECT_EQ(wired.back().weight_shift, s.weight_shift);
    }
    std::vector<const lf::Fragment*> w;
    for (const auto& s : wired) w.push_back(&s);
    EXPECT_EQ(cv::norm(composite(w), got, cv::NORM_INF), 0);
    // A dead host: the frame without its sum, against the full frame.
    auto dead_cost = [&](const std::vector<lf::Fragment>& sums, size_t* holes) {
      double worst_psnr = 1e9;
      *holes = 0;
      for (int dead = 0; dead < kHosts; ++dead) {
        std::vector<const lf::Fragment*> live;
        for (int h = 0; h < kHosts; ++h)
          if (h != dead) live.push_back(&sums[h]);
        const cv::Mat out = composite(live);
        size_t hole = 0;
        for (int y = 0; y < out.rows; ++y)
          for (int x = 0; x < out.cols; ++x)
            hole += want.at<cv::Vec4b>(y, x)[3] == 255 && out.at<cv::Vec4b>(y, x)[3] == 0;
        *holes = std::max(*holes, hole);
        worst_psnr = std::min(worst_psnr, covered_psnr(out, want));
      }
      return worst_psnr;
    };
    size_t block_holes = 0, mixed_holes = 0;
    const double block_psnr = dead_cost(blocks, &block_holes);
    const double mixed_psnr = dead_cost(mixed, &mixed_holes);
    std::printf(
        "aperture %.0f: %zu camera pixels, sums of 4x4 blocks %zu (%.2fx fewer), interleaved "
        "%zu; largest weight shift %d; against the cameras' frame: mean %.3f, max %.0f levels, "
        "%.1f dB; "
        "a dead host: blocks leave up to %zu of %zu pixels a hole (%.1f dB elsewhere), "
        "interleaved %zu (%.1f dB)\n",
        scale, camera_pixels, block_pixels, double(camera_pixels) / block_pixels, mixed_pixels,
        top_shift, diff, worst, psnr, block_holes, want.total(), block_psnr, mixed_holes,
        mixed_psnr);
    if (top_shift == 0) {
      EXPECT_EQ(worst, 0) << "sums within 8 bits composite bit for bit";
    }
    // Each bit of shift loses one bit of the sums (about 255 at a pixel).
    EXPECT_LE(worst, 3);
    EXPECT_LT(diff, 0.5);
    EXPECT_GT(psnr, 50);
    if (scale == 1.0) {
      EXPECT_LT(block_pixels * 3 / 2, camera_pixels) << "a block's fragments overlap";
      EXPECT_GT(mixed_pixels, block_pixels * 3 / 2) << "interleaved cameras' fragments do not";
      // The tent weights a pixel from the 3 cameras of its triangle only.
      EXPECT_GT(block_holes, want.total() / 20) << "a dead block leaves a hole";
      EXPECT_LT(mixed_holes, want.total() / 100) << "interleaved hosts leave almost none";
    } else {
      EXPECT_LE(block_holes, want.total() / 20) << "a wide aperture covers most of a block";
    }
  }
}

TEST(Composite, PartialSumsRefuseMismatchesAndShiftLargeSums) {
  lf::Fragment a;
  a.out_width = 8, a.out_height = 4, a.sequence = 7, a.camera_id = 3;
  a.rect = cv::Rect(1, 1, 3, 2);
  a.spans = {{{1, 4}}, {{2, 3}}};
  a.pixels.assign(4 * 4, 200);
  lf::Fragment b = a;
  b.camera_id = 4;
  b.rect = cv::Rect(2, 2, 5, 1);
  b.spans = {{{2, 7}}};
  b.pixels.assign(4 * 5, 100);
  const lf::Fragment s = lf::sum_fragments({{&a, a.pixels.data()}, {&b, b.pixels.data()}});
  EXPECT_EQ(s.rect, cv::Rect(1, 1, 6, 2));
  EXPECT_EQ(s.camera_id, 3u);
  EXPECT_EQ(s.cameras, 2);
  ASSERT_EQ(s.spans.size(), 2u);
  EXPECT_EQ(s.spans[0][0], 1);  // row 1: a's [1, 4)
  EXPECT_EQ(s.spans[0][1], 4);
  EXPECT_EQ(s.spans[1][0], 2);  // row 2: the hull of [2, 3) and [2, 7)
  EXPECT_EQ(s.spans[1][1], 7);
  // 200 + 100 = 300 at (2, 2): one bit of shift.
  EXPECT_EQ(s.weight_shift, 1);
  lf::Compositor c;
  c.reset(8, 4);
  c.add(s);
  EXPECT_EQ(c.weight_at(2, 2), 300u);
  EXPECT_EQ(c.weight_at(5, 2), 100u);
  EXPECT_EQ(c.weight_at(1, 1), 200u);
  EXPECT_EQ(c.weight_at(0, 0), 0u);
  lf::Fragment other = b;
  other.sequence = 8;
  EXPECT_THROW(lf::sum_fragments({{&a, a.pixels.data()}, {&other, other.pixels.data()}}),
               std::invalid_argument);
  other = b;
  other.layer = 1;
  EXPECT_THROW(lf::sum_fragments({{&a, a.pixels.data()}, {&other, other.pixels.data()}}),
               std::invalid_argument);
  other = b;
  other.out_width = 9;
  EXPECT_THROW(lf::sum_fragments({{&a, a.pixels.data()}, {&other, other.pixels.data()}}),
               std::invalid_argument);
  EXPECT_THROW(lf::sum_fragments({}), std::invalid_argument);
  // Empty fragments count their cameras only.
  lf::Fragment e;
  e.out_width = 8, e.out_height = 4, e.sequence = 7;
  const lf::Fragment se = lf::sum_fragments({{&e, nullptr}, {&e, nullptr}});
  EXPECT_TRUE(se.empty());
  EXPECT_EQ(se.cameras, 2);
  const auto bytes = lf::serialize_fragment(se, lf::Encoding::kRaw);
  EXPECT_EQ(bytes.size(), lf::kSumFragmentHeaderSize);
  EXPECT_EQ(lf::parse_fragment(bytes.data(), bytes.size()).cameras, 2);
}

TEST(Render, RejectsWrongImages) {
  const lf::Rig rig = lf::synthetic_grid_rig(2, 2, 0.5, 64, 48, 50);
  const auto req = view_at({0, 0, 0}, {0, 0, kDepth});
  const lf::ViewGeometry g(rig, req);
  lf::Fragment f;
  const auto plan = lf::plan_fragment(g, 0);
  EXPECT_THROW(lf::render_fragment(plan, rig.cameras[0], cv::Mat(48, 64, CV_8UC3), f),
               std::invalid_argument);
  EXPECT_THROW(lf::render_fragment(plan, rig.cameras[0], cv::Mat(40, 64, CV_8UC4), f),
               std::invalid_argument);
  std::vector<cv::Mat> too_few(3, cv::Mat(48, 64, CV_8UC4));
  EXPECT_THROW(lf::render_view(rig, too_few, req), std::invalid_argument);
}

}  // namespace

// Colour correction (lib/lf/render/colour.h), as lffragment (RGBA) and lf-render
// (BGRA) apply it: the same correction whatever the channel order.
TEST(Colour, SameCorrectionInRgbaAndBgraOrder) {
  cv::Mat rgba(7, 9, CV_8UC4);
  cv::randu(rgba, 0, 256);
  const cv::Matx34d m(1.1, 0.05, 0, 3, 0.02, 0.9, 0.03, -4, 0, 0.1, 1.2, 7);
  const cv::Mat out_rgba = lf::colour_correct(m, rgba, lf::ChannelOrder::kRGBA);
  cv::Mat bgra, out_bgra, back;
  cv::cvtColor(rgba, bgra, cv::COLOR_RGBA2BGRA);
  out_bgra = lf::colour_correct(m, bgra, lf::ChannelOrder::kBGRA);
  cv::cvtColor(out_bgra, back, cv::COLOR_BGRA2RGBA);
  EXPECT_EQ(cv::norm(out_rgba, back, cv::NORM_INF), 0);
  // One pixel by hand: A c + b, rounded and saturated; the fourth channel kept.
  const cv::Vec4b p = rgba.at<cv::Vec4b>(3, 4), q = out_rgba.at<cv::Vec4b>(3, 4);
  for (int i = 0; i < 3; ++i) {
    const double v = m(i, 0) * p[0] + m(i, 1) * p[1] + m(i, 2) * p[2] + m(i, 3);
    EXPECT_NEAR(q[i], std::min(255.0, std::max(0.0, v)), 0.5 + 1e-9) << i;
  }
  EXPECT_EQ(q[3], p[3]);
  // Identity and not opaque: the image itself, no copy; opaque: alpha 255.
  const cv::Matx34d id(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0);
  EXPECT_EQ(lf::colour_correct(id, rgba, lf::ChannelOrder::kRGBA).data, rgba.data);
  const cv::Mat opaque = lf::colour_correct(id, rgba, lf::ChannelOrder::kRGBA, true);
  std::vector<cv::Mat> ch;
  cv::split(opaque, ch);
  EXPECT_EQ(cv::countNonZero(ch[3] != 255), 0);
  EXPECT_THROW(lf::colour_correct(m, cv::Mat(2, 2, CV_8UC3), lf::ChannelOrder::kRGBA),
               std::invalid_argument);
}
