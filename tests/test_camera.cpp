// Camera model: projection round trips and the distortion inverse.
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <random>

#include "lf/geometry/camera.h"
#include "lf/geometry/projection.h"

namespace {

lf::Camera make_camera(double k1, double k2, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  lf::Camera c;
  c.width = 640;
  c.height = 480;
  c.intrinsics = {
      520.0 + 30 * u(rng), 515.0 + 30 * u(rng), 320 + 10 * u(rng), 240 + 10 * u(rng), k1, k2};
  cv::Vec3d rvec(0.3 * u(rng), 0.3 * u(rng), 0.3 * u(rng));
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  c.extrinsics = lf::Extrinsics::from_center(R, {u(rng), u(rng), u(rng)});
  return c;
}

TEST(Camera, CentreAndExtrinsicsAgree) {
  const lf::Camera c = make_camera(0, 0, 3);
  const cv::Vec3d C = c.center();
  const cv::Vec3d Xc = c.extrinsics.R * C + c.extrinsics.t;
  EXPECT_LT(cv::norm(Xc), 1e-12);
}

TEST(Camera, ProjectUnprojectRoundTrip) {
  for (const auto& k : {std::pair<double, double>{0, 0}, {-0.25, 0.12}, {0.1, -0.02}}) {
    const lf::Camera c = make_camera(k.first, k.second, 7);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> px(0, 640), py(0, 480), depth(0.5, 50);
    double worst = 0;
    for (int i = 0; i < 2000; ++i) {
      const cv::Vec2d p(px(rng), py(rng));
      const auto ray = c.unproject(p);
      ASSERT_TRUE(ray.has_value()) << "k1=" << k.first;
      EXPECT_NEAR(cv::norm(*ray), 1.0, 1e-12);
      const cv::Vec3d X = c.center() + *ray * depth(rng);
      const auto q = c.project(X);
      ASSERT_TRUE(q.has_value());
      worst = std::max(worst, cv::norm(*q - p));
    }
    EXPECT_LT(worst, 1e-8) << "k1=" << k.first << " k2=" << k.second;
  }
}

TEST(Camera, PointsBehindAreNotProjected) {
  const lf::Camera c = make_camera(0, 0, 5);
  EXPECT_FALSE(c.project(c.center() - c.forward()).has_value());
  EXPECT_FALSE(c.project(c.center()).has_value());
  EXPECT_TRUE(c.project(c.center() + c.forward()).has_value());
}

TEST(Camera, DistortionInverse) {
  lf::Intrinsics k{500, 500, 320, 240, -0.28, 0.09};
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-0.8, 0.8);
  double worst = 0;
  for (int i = 0; i < 5000; ++i) {
    const cv::Vec2d x(u(rng), u(rng));
    if (cv::norm(x) >= lf::distortion_fold_radius(k)) continue;
    const auto back = lf::undistort_normalized(k, lf::distort_normalized(k, x));
    ASSERT_TRUE(back.has_value());
    worst = std::max(worst, cv::norm(*back - x));
  }
  EXPECT_LT(worst, 1e-12);
}

TEST(Camera, DistortionFoldIsRejectedNotGarbage) {
  // Barrel distortion with k2 = 0 folds back at r^2 = -1/(3 k1).
  lf::Intrinsics k{500, 500, 320, 240, -0.3, 0.0};
  const double rf = lf::distortion_fold_radius(k);
  EXPECT_NEAR(rf, std::sqrt(1.0 / 0.9), 1e-12);
  const double rd_max = rf * (1 + k.k1 * rf * rf);
  EXPECT_FALSE(lf::undistort_normalized(k, {rd_max * 1.01, 0}).has_value());
  EXPECT_FALSE(lf::undistort_normalized(k, {NAN, 0}).has_value());
  const auto inside = lf::undistort_normalized(k, {rd_max * 0.9, 0});
  ASSERT_TRUE(inside.has_value());
  EXPECT_LT((*inside)[0], rf);
  // No distortion: identity; scaled intrinsics keep pixel centres consistent.
  lf::Intrinsics k0{500, 400, 319.5, 239.5, 0, 0};
  EXPECT_EQ(*lf::undistort_normalized(k0, {0.3, -0.2}), cv::Vec2d(0.3, -0.2));
  const lf::Intrinsics h = k0.scaled(0.5);
  EXPECT_DOUBLE_EQ(h.cx, 159.5);
  EXPECT_DOUBLE_EQ(h.fy, 200.0);
}

}  // namespace
