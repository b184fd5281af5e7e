// Calibration on real data: Zhang intrinsics against published results
// (Bouguet's toolbox example, OpenCV's sample chessboards) and the radial
// model choice; Ceres bundle adjustment of a real BAL problem against a
// reference solve with the settings of Ceres's own bundle_adjuster example.
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "calib/bundle.h"
#include "calib/intrinsics.h"
#include "helpers.h"

namespace {

using testing_lf::data_path;

std::vector<std::string> images(const std::string& dir, const std::string& prefix) {
  std::vector<std::string> v;
  for (const auto& e : std::filesystem::directory_iterator(data_path(dir)))
    if (e.path().filename().string().rfind(prefix, 0) == 0) v.push_back(e.path().string());
  std::sort(v.begin(), v.end());
  return v;
}

TEST(Intrinsics, CaltechTwoRadialTermsMatchTheToolbox) {
  // Bouguet's toolbox: fc = [657.46, 657.95], cc = [303.14, 242.57],
  // kc = [-0.2540, 0.1214, ...] (4-coefficient model; tangential terms tiny).
  const auto views = lf::calib::detect_chessboards(images("caltech-calib", "Image"));
  EXPECT_EQ(views.pattern, cv::Size(13, 12));
  EXPECT_EQ(views.used.size(), 20u);
  const auto fit = lf::calib::calibrate_intrinsics(views, 30.0, lf::calib::RadialModel::kK1K2);
  std::printf("caltech: fx %.2f fy %.2f cx %.2f cy %.2f k1 %.4f k2 %.4f RMS %.3f px\n", fit.fx,
              fit.fy, fit.cx, fit.cy, fit.k1, fit.k2, fit.rms_px);
  EXPECT_NEAR(fit.fx, 657.46, 0.005 * 657.46);
  EXPECT_NEAR(fit.fy, 657.95, 0.005 * 657.95);
  EXPECT_NEAR(fit.cx, 303.14, 2.0);
  EXPECT_NEAR(fit.cy, 242.57, 2.0);
  EXPECT_NEAR(fit.k1, -0.254, 0.01);
  EXPECT_NEAR(fit.k2, 0.12, 0.05);
  EXPECT_LT(fit.rms_px, 0.5);
  // Uncertainties are reported and small against the values.
  EXPECT_GT(fit.sigma[0], 0.0);
  EXPECT_LT(fit.sigma[0], 2.0);
}

TEST(Intrinsics, OpenCvLeftChessboardsMatchOpenCvsResult) {
  // OpenCV's calibration of the left images: fx = fy = 535.92, cx = 342.28,
  // cy = 235.57 (5-coefficient model, fixed aspect ratio).
  const auto views = lf::calib::detect_chessboards(images("opencv-chessboard", "left"));
  EXPECT_EQ(views.pattern, cv::Size(9, 6));
  const auto fit = lf::calib::calibrate_intrinsics(views, 25.0, lf::calib::RadialModel::kK1K2);
  std::printf("opencv left: fx %.2f fy %.2f cx %.2f cy %.2f k1 %.4f k2 %.4f RMS %.3f px\n", fit.fx,
              fit.fy, fit.cx, fit.cy, fit.k1, fit.k2, fit.rms_px);
  EXPECT_NEAR(fit.fx, 536.0, 0.01 * 536.0);
  EXPECT_NEAR(fit.fy, 536.0, 0.01 * 536.0);
  EXPECT_NEAR(fit.cx, 342.0, 5.0);
  EXPECT_NEAR(fit.cy, 236.0, 5.0);
}

TEST(Intrinsics, RadialModelIsChosenByEvidence) {
  // Caltech's lens has strong barrel distortion: k1 alone is not enough (k2
  // lowers the held-out error by 9 %); k3 is significant but buys < 1 %:
  // the paper's two radial terms.
  const auto views = lf::calib::detect_chessboards(images("caltech-calib", "Image"));
  std::string why;
  const auto fit = lf::calib::choose_radial_model(views, 30.0, &why);
  std::printf("%s\n", why.c_str());
  EXPECT_EQ(fit.model, lf::calib::RadialModel::kK1K2);
  EXPECT_GT(std::abs(fit.k2), 3 * fit.sigma[5]);
  EXPECT_GT(fit.holdout_rms_px, fit.rms_px * 0.9);  // held-out error is not below the fit's
  EXPECT_NE(why.find("chosen"), std::string::npos);
}

TEST(Intrinsics, BadInputIsAClearError) {
  EXPECT_THROW(lf::calib::detect_chessboards({}), std::invalid_argument);
  try {
    lf::calib::detect_chessboards({"/nonexistent/a.png", "/nonexistent/b.png"});
    FAIL() << "accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("no readable image"), std::string::npos) << e.what();
  }
  // Images without a checkerboard (the Chess light field) are rejected by name.
  const auto chess = images("stanford-chess", "out_00_0");
  ASSERT_GE(chess.size(), 3u);
  try {
    lf::calib::detect_chessboards({chess[0], chess[1], chess[2]}, cv::Size(9, 6));
    FAIL() << "accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("only 0 images"), std::string::npos) << e.what();
  }
}

// The reference: Ceres's examples/bundle_adjuster.cc model (SnavelyReprojectionError)
// and solver settings (sparse Schur, Levenberg-Marquardt, points eliminated
// first), written out here independently of calib/bundle.cpp.
struct SnavelyReference {
  SnavelyReference(double x, double y) : x(x), y(y) {}
  template <typename T>
  bool operator()(const T* const camera, const T* const point, T* residuals) const {
    T p[3];
    ceres::AngleAxisRotatePoint(camera, point, p);
    p[0] += camera[3];
    p[1] += camera[4];
    p[2] += camera[5];
    const T xp = -p[0] / p[2];
    const T yp = -p[1] / p[2];
    const T r2 = xp * xp + yp * yp;
    const T distortion = 1.0 + r2 * (camera[7] + camera[8] * r2);
    residuals[0] = camera[6] * distortion * xp - x;
    residuals[1] = camera[6] * distortion * yp - y;
    return true;
  }
  double x, y;
};

TEST(Bundle, Ladybug49AgreesWithTheReferenceSolve) {
  const std::string file = data_path("bal-ladybug-49/problem-49-7776-pre.txt");
  lf::calib::BundleProblem ours = lf::calib::read_bal(file);
  ASSERT_EQ(ours.num_cameras, 49);
  ASSERT_EQ(ours.num_points, 7776);
  ASSERT_EQ(ours.observations.size(), 31843u);
  lf::calib::BundleProblem ref = ours;
  lf::calib::BundleOptions opt;
  opt.max_iterations = 50;
  const auto report = lf::calib::bundle_adjust(ours, opt);

  ceres::Problem problem;
  for (const auto& o : ref.observations)
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<SnavelyReference, 2, 9, 3>(new SnavelyReference(o.x, o.y)),
        nullptr, &ref.cameras[9 * o.camera], &ref.points[3 * o.point]);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.max_num_iterations = 50;
  auto* ordering = new ceres::ParameterBlockOrdering;
  for (int i = 0; i < ref.num_points; ++i) ordering->AddElementToGroup(&ref.points[3 * i], 0);
  for (int i = 0; i < ref.num_cameras; ++i) ordering->AddElementToGroup(&ref.cameras[9 * i], 1);
  so.linear_solver_ordering.reset(ordering);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);

  std::printf(
      "ladybug-49: ours %s\n  cost %.6g -> %.6g, RMS %.4f -> %.4f px\n"
      "  reference: cost %.6g -> %.6g\n",
      report.summary.c_str(), report.initial_cost, report.final_cost, report.initial_rms_px,
      report.final_rms_px, summary.initial_cost, summary.final_cost);
  EXPECT_NEAR(report.initial_cost, summary.initial_cost, 1e-9 * summary.initial_cost);
  EXPECT_NEAR(report.final_cost, summary.final_cost, 1e-3 * summary.final_cost);
  EXPECT_LT(report.final_cost, 0.05 * report.initial_cost);  // it did adjust
  EXPECT_LT(report.final_rms_px, 1.0);
}

TEST(Bundle, MalformedBalFilesAreClearErrors) {
  const auto dir = std::filesystem::temp_directory_path() / "lf-test-bal";
  std::filesystem::create_directories(dir);
  auto expect = [&](const std::string& text, const std::string& word) {
    const auto f = (dir / "p.txt").string();
    std::ofstream(f) << text;
    try {
      lf::calib::read_bal(f);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
  };
  expect("0 1 1\n", "bad header");
  expect("1 1 1\n0 5 1.0 2.0\n", "out of range");
  expect("1 1 1\n0 0 1.0\n", "truncated");
  expect("1 1 1\n0 0 1.0 2.0\n1 2 3 4 5 6 7 8\n", "camera parameters");
  expect("1 1 1\n0 0 1.0 2.0\n1 2 3 4 5 6 7 8 9\n1 2 nan\n", "point");
  EXPECT_THROW(lf::calib::read_bal("/nonexistent/problem.txt"), std::runtime_error);
  std::filesystem::remove_all(dir);
}

}  // namespace
