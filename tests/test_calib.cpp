// Calibration on real data: Zhang intrinsics against published results
// (Bouguet's toolbox example, OpenCV's sample chessboards) and the radial
// model choice; Ceres bundle adjustment of a real BAL problem against a
// reference solve with the settings of Ceres's own bundle_adjuster example.
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <random>

#include "calib/bundle.h"
#include "calib/colour.h"
#include "calib/intrinsics.h"
#include "calib/reprojection_error.h"
#include "calib/selfcal.h"
#include "calib/synthetic_point_light.h"
#include "calib/tracking.h"
#include "helpers.h"
#include "lf/focus/focus.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/parse.h"
#include "lf/io/rig_file.h"
#include "lf/quality/quality.h"
#include "lf/quality/synthetic.h"
#include "lf/render/composite.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"

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
  LF_NEEDS_DATA("caltech-calib");
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
  LF_NEEDS_DATA("opencv-chessboard");
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
  LF_NEEDS_DATA("caltech-calib");
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
  LF_NEEDS_DATA("stanford-chess");
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
// first), written out here independently of calib/bundle.cpp and
// lf/geometry/projection.h on purpose: it is the published model the solve is checked
// against, not a second copy of ours.
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
  LF_NEEDS_DATA("bal-ladybug-49");
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

namespace {

// Similarity world_true = s Q world_est + T from two rigs of the same
// cameras: Q from the camera orientations (the mean of R_true^T R_est,
// projected onto a rotation: nearly coplanar centres alone fix the tilt
// poorly), s and T by least squares on the camera centres.
void align(const lf::Rig& est, const lf::Rig& truth, double& s, cv::Matx33d& Q, cv::Vec3d& T) {
  std::vector<cv::Vec3d> a, b;
  cv::Matx33d M = cv::Matx33d::zeros();
  for (const auto& c : est.cameras) {
    const lf::Camera& t = truth.cameras[truth.index_of(c.id)];
    a.push_back(c.center());
    b.push_back(t.center());
    M += t.extrinsics.R.t() * c.extrinsics.R;
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(cv::Mat(M), w, u, vt);
  cv::Mat D = cv::Mat::eye(3, 3, CV_64F);
  if (cv::determinant(u * vt) < 0) D.at<double>(2, 2) = -1;
  Q = cv::Matx33d(cv::Mat(u * D * vt));
  cv::Vec3d ma(0, 0, 0), mb(0, 0, 0);
  for (size_t i = 0; i < a.size(); ++i) ma += a[i], mb += b[i];
  ma /= static_cast<double>(a.size());
  mb /= static_cast<double>(a.size());
  double num = 0, den = 0;
  for (size_t i = 0; i < a.size(); ++i)
    num += (Q * (a[i] - ma)).dot(b[i] - mb), den += (a[i] - ma).dot(a[i] - ma);
  s = num / den;
  T = mb - s * (Q * ma);
}

struct RigErrors {
  double centre_max = 0, rot_max_deg = 0, f_max_rel = 0;
};

RigErrors compare(const lf::Rig& est, const lf::Rig& truth) {
  std::vector<cv::Vec3d> a, b;
  std::vector<const lf::Camera*> t;
  for (const auto& c : est.cameras) {
    const int k = truth.index_of(c.id);
    a.push_back(c.center());
    b.push_back(truth.cameras[k].center());
    t.push_back(&truth.cameras[k]);
  }
  double s;
  cv::Matx33d Q;
  cv::Vec3d T;
  align(est, truth, s, Q, T);
  RigErrors e;
  for (size_t i = 0; i < a.size(); ++i) {
    e.centre_max = std::max(e.centre_max, cv::norm(s * (Q * a[i]) + T - b[i]));
    // World rotation Q: R_true ~ R_est Q^T.
    const cv::Matx33d D = t[i]->extrinsics.R.t() * est.cameras[i].extrinsics.R * Q.t();
    const double c = std::clamp((cv::trace(D) - 1) / 2, -1.0, 1.0);
    e.rot_max_deg = std::max(e.rot_max_deg, std::acos(c) * 180 / CV_PI);
    e.f_max_rel =
        std::max(e.f_max_rel, std::abs(est.cameras[i].intrinsics.fx / t[i]->intrinsics.fx - 1));
  }
  return e;
}

}  // namespace

TEST(SelfCal, Synthetic8x8RigIsRecovered) {
  // 8x8 grid, 10 cm pitch, +-2 degree jitter, 200 light positions 1.5-4 m
  // away, 0.3 px noise, 3 % outliers, 5 % dropouts; identical lenses (the
  // Zhang camera's f measured 0.05 % off).
  lf::calib::SyntheticPointLightOptions so;
  so.f_spread = std::getenv("LF_F_SPREAD") ? std::atof(std::getenv("LF_F_SPREAD")) : 0.0;
  const auto data = lf::calib::make_synthetic_point_light(so);
  lf::calib::SelfCalOptions opt;
  opt.pitch = so.pitch;
  const auto r =
      lf::calib::self_calibrate(data.truth.cameras, 0, data.zhang, data.observations, opt);
  std::printf("%s", r.log.c_str());
  ASSERT_FALSE(r.degenerate) << r.degenerate_reason;
  EXPECT_EQ(r.rig.cameras.size(), 64u);
  // Topology: the 8x8 grid, each camera in its true cell.
  ASSERT_EQ(r.rig.grid.rows, 8);
  ASSERT_EQ(r.rig.grid.cols, 8);
  for (int row = 0; row < 8; ++row)
    for (int c = 0; c < 8; ++c)
      EXPECT_EQ(r.rig.cameras[r.rig.grid.at(row, c)].id,
                data.truth.cameras[data.truth.grid.at(row, c)].id);
  // RMS at the noise floor (within 10 %).
  const double floor = so.noise_px * r.noise_floor_factor;
  std::printf("RMS %.4f px, noise floor %.4f px\n", r.rms_px, floor);
  EXPECT_NEAR(r.rms_px, floor, 0.1 * floor);
  // Outliers flagged.
  size_t truly = 0, caught = 0, false_alarms = 0;
  for (size_t i = 0; i < data.observations.size(); ++i) {
    truly += data.is_outlier[i];
    caught += data.is_outlier[i] && r.outlier[i];
    false_alarms += !data.is_outlier[i] && r.outlier[i];
  }
  std::printf("outliers: %zu of %zu flagged, %zu false alarms\n", caught, truly, false_alarms);
  EXPECT_GE(caught, 0.95 * truly);
  EXPECT_LE(false_alarms, 0.01 * data.observations.size());
  // The rig after similarity alignment.
  const RigErrors e = compare(r.rig, data.truth);
  std::printf("centres within %.3f mm, rotations within %.4f deg, f within %.3f %%\n",
              1000 * e.centre_max, e.rot_max_deg, 100 * e.f_max_rel);
  EXPECT_LT(e.centre_max, 0.002);
  EXPECT_LT(e.rot_max_deg, 0.05);
  EXPECT_LT(e.f_max_rel, 0.003);
  // Principal points: not pinned by the tracks on a parallel grid (they
  // trade off against rotation), so held at the Zhang camera's.
  std::vector<double> pps(r.principal_point_sigma.begin(), r.principal_point_sigma.end());
  std::sort(pps.begin(), pps.end());
  std::printf("principal point sigma (all free): median %.2f px\n", pps[pps.size() / 2]);
  EXPECT_GT(pps[pps.size() / 2], 1.0);
  for (const auto& c : r.rig.cameras) EXPECT_EQ(c.intrinsics.cx, data.zhang.cx);
  // Uncertainties reported: f (prior-dominated on a parallel grid), poses.
  double worst_rot = 0, worst_t = 0;
  for (size_t c = 0; c < 64; ++c) {
    EXPECT_GT(r.f_sigma[c], 0.0);
    EXPECT_GT(r.intrinsics_sigma[c][1], 0.0);
    EXPECT_GE(r.rotation_sigma_deg[c], 0.0);
    worst_rot = std::max(worst_rot, r.rotation_sigma_deg[c]);
    worst_t = std::max(worst_t, r.translation_sigma[c]);
  }
  std::printf("sigmas: f %.3f px (camera 1), rotation <= %.4f deg, translation <= %.3f mm\n",
              r.f_sigma[1], worst_rot, 1000 * worst_t);
  // (Relative to the gauge camera, so they grow with distance from it; not
  // comparable with the errors after a similarity alignment above.)
  EXPECT_GT(worst_rot, 0.0);
  EXPECT_GT(worst_t, 0.0);
}

TEST(SelfCal, SharedFreeFocalLengthOnAParallelGridIsDegenerate) {
  lf::calib::SyntheticPointLightOptions so;
  so.f_spread = 0;
  const auto data = lf::calib::make_synthetic_point_light(so);
  lf::calib::SelfCalOptions opt;
  opt.f_prior = 0;  // one shared, free focal length
  const auto r =
      lf::calib::self_calibrate(data.truth.cameras, 0, data.zhang, data.observations, opt);
  std::printf("%s", r.log.c_str());
  EXPECT_TRUE(r.degenerate);
  EXPECT_NE(r.degenerate_reason.find("focal length"), std::string::npos) << r.degenerate_reason;
}

TEST(SelfCal, LightSweptInOnePlaneIsDegenerate) {
  lf::calib::SyntheticPointLightOptions so;
  so.z_min = so.z_max = 2.5;
  const auto data = lf::calib::make_synthetic_point_light(so);
  const auto r = lf::calib::self_calibrate(data.truth.cameras, 0, data.zhang, data.observations);
  std::printf("%s", r.log.c_str());
  EXPECT_TRUE(r.degenerate);
  EXPECT_NE(r.degenerate_reason.find("plane"), std::string::npos) << r.degenerate_reason;
}

TEST(SelfCal, TracksNotCoveringTheImagesAreDegenerate) {
  // The light stays in a narrow cone in front of the array's centre.
  lf::calib::SyntheticPointLightOptions so;
  so.lights = 1500;
  auto data = lf::calib::make_synthetic_point_light(so);
  std::vector<lf::calib::PointObservation> kept;
  for (const auto& ob : data.observations) {
    const cv::Vec3d& L = data.lights[ob.point];
    if (std::abs(L[0] / L[2]) < 0.06 && std::abs(L[1] / L[2]) < 0.06) kept.push_back(ob);
  }
  const auto r = lf::calib::self_calibrate(data.truth.cameras, 0, data.zhang, kept);
  std::printf("%s", r.log.c_str());
  EXPECT_TRUE(r.degenerate);
  EXPECT_NE(r.degenerate_reason.find("cover"), std::string::npos) << r.degenerate_reason;
}

TEST(SelfCal, TooFewPointsIsDegenerate) {
  lf::calib::SyntheticPointLightOptions so;
  so.lights = 12;
  const auto data = lf::calib::make_synthetic_point_light(so);
  const auto r = lf::calib::self_calibrate(data.truth.cameras, 0, data.zhang, data.observations);
  EXPECT_TRUE(r.degenerate);
  EXPECT_THROW(lf::calib::self_calibrate(data.truth.cameras, 0, data.zhang, {}),
               std::invalid_argument);
}

TEST(Tracking, SpotCentresAreSubPixelAndBadFramesRejected) {
  lf::Camera cam;
  cam.width = 320;
  cam.height = 240;
  cam.intrinsics.fx = cam.intrinsics.fy = 300;
  cam.intrinsics.cx = 159.5;
  cam.intrinsics.cy = 119.5;
  double worst = 0;
  for (int k = 0; k < 20; ++k) {
    const cv::Vec3d L(-0.3 + 0.031 * k, 0.2 - 0.017 * k, 2.0);
    const cv::Mat f = lf::calib::render_point_light(cam, L, 1.2, 200, 2, k + 1);
    const auto s = lf::calib::find_spot(f);
    ASSERT_EQ(s.status, lf::calib::SpotStatus::kFound) << s.why;
    const cv::Vec2d truth = *cam.project(L);
    worst = std::max(worst, cv::norm(cv::Vec2d(s.centre.x, s.centre.y) - truth));
  }
  std::printf("spot centroid error: max %.4f px\n", worst);
  EXPECT_LT(worst, 0.1);
  // Dark frame: none. Two lights: several. A motion streak, a saturated blob.
  EXPECT_EQ(lf::calib::find_spot(cv::Mat(240, 320, CV_8U, cv::Scalar(5))).status,
            lf::calib::SpotStatus::kNone);
  cv::Mat two = lf::calib::render_point_light(cam, {0, 0, 2}) +
                lf::calib::render_point_light(cam, {0.3, 0.1, 2});
  EXPECT_EQ(lf::calib::find_spot(two).status, lf::calib::SpotStatus::kSeveral);
  cv::Mat streak(240, 320, CV_8U, cv::Scalar(5));
  cv::line(streak, {100, 100}, {140, 110}, cv::Scalar(200), 3);
  EXPECT_EQ(lf::calib::find_spot(streak).status, lf::calib::SpotStatus::kStreak);
  // A GStreamer source (as a live camera would be): dark frames, no spots.
  std::vector<lf::calib::TrackStats> st;
  const auto none = lf::calib::track_point_light(
      {"gst:videotestsrc num-buffers=4 pattern=black ! video/x-raw,width=64,height=48"}, &st);
  EXPECT_TRUE(none.empty());
  ASSERT_EQ(st.size(), 1u);
  EXPECT_EQ(st[0].frames, 4);
  EXPECT_EQ(st[0].none, 4);
  EXPECT_THROW(lf::calib::track_point_light({"/nonexistent/cam.avi"}), std::runtime_error);
  cv::Mat blob(240, 320, CV_8U, cv::Scalar(5));
  cv::circle(blob, {160, 120}, 6, cv::Scalar(255), cv::FILLED);
  EXPECT_EQ(lf::calib::find_spot(blob).status, lf::calib::SpotStatus::kStreak);
}

TEST(SelfCal, EndToEndFromSimulatedVideosToRenders) {
  // Simulated point-light videos (Motion JPEG AVI, one per camera) of a 4x4
  // rig -> lf-calibrate -> rig file -> render of a textured plane through
  // the calibrated rig, against the render through the true rig.
  lf::calib::SyntheticPointLightOptions so;
  so.rows = so.cols = 4;
  so.width = 320;
  so.height = 240;
  so.f = 300;
  so.lights = 150;
  so.f_spread = 0;  // identical lenses, as in the 8x8 test
  // The Zhang camera's f exact here: its error (0.05 % is Caltech's 1-sigma)
  // passes unchanged into every camera (the tracks cannot correct it on a
  // parallel grid) and costs 0.57 dB on its own at 320x240 (LF_ZHANG_ERROR).
  so.zhang_f_error = std::getenv("LF_ZHANG_ERROR") ? std::atof(std::getenv("LF_ZHANG_ERROR")) : 0.0;
  const auto data = lf::calib::make_synthetic_point_light(so);
  const auto dir = std::filesystem::temp_directory_path() / "lf-test-e2e-calib";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "tracks");
  for (size_t c = 0; c < data.truth.cameras.size(); ++c) {
    char name[32];
    std::snprintf(name, sizeof name, "cam%02zu.avi", c);
    cv::VideoWriter w((dir / "tracks" / name).string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                      15, cv::Size(so.width, so.height), false);
    ASSERT_TRUE(w.isOpened());
    for (size_t p = 0; p < data.lights.size(); ++p)
      w.write(lf::calib::render_point_light(data.truth.cameras[c], data.lights[p], 1.2, 200, 1,
                                            c * 1000 + p + 1));
  }
  // Colour samples of a shared target: random gains and offsets; camera 3's
  // red control stuck (gain 0.3).
  {
    std::ofstream csv(dir / "colour.csv");
    std::mt19937_64 rng(9);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<cv::Vec3d> target;
    for (int k = 0; k < 40; ++k)
      target.push_back({30 + 190 * u(rng), 30 + 190 * u(rng), 30 + 190 * u(rng)});
    for (int c = 0; c < 16; ++c) {
      cv::Vec3d g(0.85 + 0.3 * u(rng), 0.85 + 0.3 * u(rng), 0.85 + 0.3 * u(rng));
      if (c == 3) g[0] = 0.3;
      const cv::Vec3d b(-10 + 20 * u(rng), -10 + 20 * u(rng), -10 + 20 * u(rng));
      for (const auto& t : target)
        csv << c << "," << g[0] * t[0] + b[0] << "," << g[1] * t[1] + b[1] << ","
            << g[2] * t[2] + b[2] << "\n";
    }
  }
  const lf::Intrinsics& z = data.zhang;
  char cmd[1024];
  std::snprintf(cmd, sizeof cmd,
                "%s/lf-calibrate --tracks %s --zhang-intrinsics %.9g,%.9g,%.9g,%.9g,%.9g "
                "--pitch %g --unit m --colour-samples %s --out %s > %s 2>&1",
                LF_TOOLS_DIR, (dir / "tracks").c_str(), z.fx, z.cx, z.cy, z.k1, z.k2, so.pitch,
                (dir / "colour.csv").c_str(), (dir / "rig.json").c_str(),
                (dir / "log.txt").c_str());
  const int rc = std::system(cmd);
  {
    std::ifstream log(dir / "log.txt");
    std::printf("%s\n", std::string(std::istreambuf_iterator<char>(log), {}).c_str());
  }
  ASSERT_EQ(rc, 0);
  for (const char* f : {"report.txt", "residuals.png", "histogram.png", "layout.png"})
    EXPECT_TRUE(std::filesystem::exists(dir / f)) << f;
  lf::Rig est = lf::load_rig((dir / "rig.json").string());
  ASSERT_EQ(est.cameras.size(), 16u);
  for (const auto& c : est.cameras)  // colour corrections in the rig, the defective camera left out
    EXPECT_EQ(c.has_colour_correction(), c.id != 3) << c.id;
  // Into the true rig's frame (the calibrated frame is camera 0's, scaled to
  // the pitch).
  double s;
  cv::Matx33d Q;
  cv::Vec3d T;
  align(est, data.truth, s, Q, T);
  for (auto& c : est.cameras)
    c.extrinsics = lf::Extrinsics::from_center(c.extrinsics.R * Q.t(), s * (Q * c.center()) + T);
  est.finalize();
  const RigErrors e = compare(est, data.truth);
  std::printf("end to end: centres within %.3f mm, rotations within %.4f deg, f within %.3f %%\n",
              1000 * e.centre_max, e.rot_max_deg, 100 * e.f_max_rel);
  // Render a textured plane 3 m away from a view between the cameras.
  const double depth = 3.0, period = 0.05;
  std::vector<cv::Mat> images;
  for (const auto& c : data.truth.cameras)
    images.push_back(lf::render_textured_plane(c, depth, period));
  lf::ViewRequest req;
  req.view = lf::view_between_cameras(data.truth, {0.023, -0.031, 0}, 320, 240);
  req.focal_plane = lf::FocalPlane::through({0, 0, depth}, {0, 0, 1});
  lf::Camera eye;
  eye.width = 320;
  eye.height = 240;
  eye.intrinsics = req.view.intrinsics();
  eye.extrinsics = lf::Extrinsics::from_center(req.view.R, req.view.position);
  const cv::Mat truth_img = lf::render_textured_plane(eye, depth, period);
  std::vector<cv::Mat> est_images;  // the same camera images, in the estimated rig's order
  for (const auto& c : est.cameras) est_images.push_back(images[data.truth.index_of(c.id)]);
  const double p_true = lf::psnr(lf::render_view(data.truth, images, req), truth_img, 12);
  const double p_est = lf::psnr(lf::render_view(est, est_images, req), truth_img, 12);
  std::printf("PSNR against the ground truth: true rig %.2f dB, calibrated rig %.2f dB\n", p_true,
              p_est);
  EXPECT_GT(p_true, 25.0);
  EXPECT_GT(p_est, p_true - 0.5);
  std::filesystem::remove_all(dir);
}

TEST(Colour, DeltaE2000MatchesSharmasTestData) {
  // Sharma, Wu, Dalal (2005), Table 1, pairs 1, 7, 14, 17.
  EXPECT_NEAR(lf::calib::delta_e2000({50, 2.6772, -79.7751}, {50, 0, -82.7485}), 2.0425, 1e-4);
  EXPECT_NEAR(lf::calib::delta_e2000({50, 0, 0}, {50, -1, 2}), 2.3669, 1e-4);
  EXPECT_NEAR(lf::calib::delta_e2000({50, 2.5, 0}, {61, -5, 29}), 22.8977, 1e-4);
  EXPECT_NEAR(lf::calib::delta_e2000({50, 2.5, 0}, {73, 25, -18}), 27.1492, 1e-4);
  const cv::Vec3d white = lf::calib::srgb_to_lab({255, 255, 255});
  EXPECT_NEAR(white[0], 100.0, 1e-3);
  EXPECT_NEAR(white[1], 0.0, 1e-2);
}

TEST(Colour, CamerasAreCorrectedAndADefectiveOneIsFlagged) {
  // 16 cameras see 64 shared colour samples through random gains (+-15 %),
  // offsets (+-12 levels) and channel crosstalk (+-6 %), with 0.5 levels of
  // noise; camera 5's blue control is stuck (gain 0.35).
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, 0.5);
  std::vector<cv::Vec3d> truth;
  for (int k = 0; k < 64; ++k)
    truth.push_back({25 + 205 * u(rng), 25 + 205 * u(rng), 25 + 205 * u(rng)});
  std::vector<std::vector<cv::Vec3d>> samples(16);
  for (int c = 0; c < 16; ++c) {
    cv::Matx33d A;
    cv::Vec3d b;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) A(i, j) = i == j ? 0.85 + 0.3 * u(rng) : -0.06 + 0.12 * u(rng);
      b[i] = -12 + 24 * u(rng);
    }
    if (c == 5) A(2, 2) = 0.35;
    for (const auto& t : truth) {
      cv::Vec3d m = A * t + b;
      for (int i = 0; i < 3; ++i) m[i] = std::clamp(std::round(m[i] + noise(rng)), 0.0, 255.0);
      samples[c].push_back(m);
    }
  }
  const auto r = lf::calib::calibrate_colours(samples);
  std::printf("%s", r.report.c_str());
  for (int c = 0; c < 16; ++c)
    EXPECT_EQ(r.cameras[c].defective, c == 5) << c << ": " << r.cameras[c].why;
  EXPECT_GT(r.mean_delta_e_before, 3.0);
  EXPECT_LT(r.mean_delta_e_after, 1.0);
  // Crosstalk is present: the affine model is chosen for most cameras.
  int affine = 0;
  for (const auto& cc : r.cameras) affine += cc.model == lf::calib::ColourModel::kAffine;
  EXPECT_GE(affine, 12);
  EXPECT_THROW(lf::calib::calibrate_colours({{{1, 2, 3}}}), std::invalid_argument);
}

TEST(Colour, SamplesFromImagesOfTheCommonScene) {
  // 16 cameras image a textured plane 2 m away; each camera's colours are
  // distorted (gain, offset, crosstalk), camera 9's green is stuck low. The
  // samples come from the images through the plane.
  const lf::Rig rig = lf::synthetic_grid_rig(4, 4, 0.1, 320, 240, 40, 1.0, 3);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<cv::Mat> images;
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    cv::Mat bgra = lf::render_textured_plane(rig.cameras[c], 2.0, 0.4), rgb;
    cv::cvtColor(bgra, rgb, cv::COLOR_BGRA2RGB);
    cv::Matx34d M;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) M(i, j) = i == j ? 0.85 + 0.3 * u(rng) : -0.05 + 0.1 * u(rng);
      M(i, 3) = -10 + 20 * u(rng);
    }
    if (c == 9) M(1, 1) = 0.3;
    cv::transform(rgb, rgb, M);
    images.push_back(rgb);
  }
  const auto samples = lf::calib::colour_samples_from_images(
      rig, images, lf::FocalPlane::through({0, 0, 2.0}, {0, 0, 1}));
  ASSERT_GE(samples[0].size(), 24u);
  const auto r = lf::calib::calibrate_colours(samples);
  std::printf("%zu samples\n%s", samples[0].size(), r.report.c_str());
  for (size_t c = 0; c < 16; ++c) EXPECT_EQ(r.cameras[c].defective, c == 9) << c;
  EXPECT_LT(r.mean_delta_e_after, 1.0);
  EXPECT_GT(r.mean_delta_e_before, 2.0);
}

// The Ceres cost functors evaluate the same projection as lf::Camera::project
// (one camera model: lf/geometry/projection.h).
TEST(ReprojectionError, MatchesCameraProject) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    lf::Camera cam;
    cam.width = 640, cam.height = 480;
    cam.intrinsics = {500 + 100 * U(rng), 0, 320 + 20 * U(rng), 240 + 20 * U(rng), 0.2 * U(rng),
                      0.05 * U(rng)};
    cam.intrinsics.fy = cam.intrinsics.fx;
    const cv::Vec3d aa(0.3 * U(rng), 0.3 * U(rng), 0.3 * U(rng));
    cv::Matx33d R;
    cv::Rodrigues(aa, R);
    cam.extrinsics.R = R;
    cam.extrinsics.t = {U(rng), U(rng), U(rng)};
    const cv::Vec3d X = cam.extrinsics.R.t() *
                        (cv::Vec3d(0.4 * U(rng), 0.3 * U(rng), 3 + U(rng)) - cam.extrinsics.t);
    const auto uv = cam.project(X);
    ASSERT_TRUE(uv.has_value());
    const double pose[6] = {
        aa[0], aa[1], aa[2], cam.extrinsics.t[0], cam.extrinsics.t[1], cam.extrinsics.t[2]};
    const double intr[3] = {cam.intrinsics.fx, cam.intrinsics.k1, cam.intrinsics.k2};
    const double pp[2] = {cam.intrinsics.cx, cam.intrinsics.cy};
    double r[2];
    ASSERT_TRUE(lf::calib::ReprojectionError((*uv)[0], (*uv)[1])(pose, intr, pp, X.val, r));
    EXPECT_NEAR(r[0], 0, 1e-9);
    EXPECT_NEAR(r[1], 0, 1e-9);
    // Through Ceres (automatic differentiation) as the solver calls it.
    std::unique_ptr<ceres::CostFunction> cost(
        lf::calib::ReprojectionError::Create((*uv)[0] + 1.5, (*uv)[1] - 0.5));
    const double* blocks[4] = {pose, intr, pp, X.val};
    ASSERT_TRUE(cost->Evaluate(blocks, r, nullptr));
    EXPECT_NEAR(r[0], 1.5 * -1, 1e-9);
    EXPECT_NEAR(r[1], 0.5, 1e-9);
    // BAL layout, principal point at 0, camera looking down +z (sign +1).
    const double bal[9] = {aa[0],   aa[1],   aa[2],   pose[3], pose[4],
                           pose[5], intr[0], intr[1], intr[2]};
    ASSERT_TRUE(
        lf::calib::BalReprojectionError((*uv)[0] - pp[0], (*uv)[1] - pp[1], 1.0)(bal, X.val, r));
    EXPECT_NEAR(r[0], 0, 1e-9);
    EXPECT_NEAR(r[1], 0, 1e-9);
  }
}
