// Intrinsic calibration of one camera by Zhang's method (Z. Zhang, "A
// flexible new technique for camera calibration", PAMI 2000) through
// OpenCV: checkerboard corners (cv::findChessboardCornersSB + cornerSubPix),
// then cv::calibrateCamera (extended: standard deviations) with no tangential terms. This is step 1
// of the paper's calibration (Yang et al. 2002, 4.4.2): the paper's camera
// model has f, the principal point and two radial terms k1, k2.
//
// Conventions: pixel coordinates with (0, 0) at the centre of the top-left
// pixel (OpenCV's); radial distortion x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6)
// on normalised coordinates (OpenCV's, the same as lf::Intrinsics for k1, k2).
// Errors: std::invalid_argument / std::runtime_error naming the input.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace lf::calib {

// Checkerboard corners found in a set of images of one camera.
struct ChessboardViews {
  cv::Size image_size;
  cv::Size pattern;                               // inner corners (columns, rows)
  std::vector<std::string> used;                  // images with the whole pattern
  std::vector<std::string> rejected;              // images without it (named in reports)
  std::vector<std::vector<cv::Point2f>> corners;  // per used image, sub-pixel
};

// Finds the pattern in every image. pattern == {0, 0}: tries the sizes from
// 4x3 to 16x16 inner corners on the first readable image and keeps the
// largest found. Throws if no image is readable, images differ in size, or
// fewer than 3 views show the pattern.
ChessboardViews detect_chessboards(const std::vector<std::string>& files, cv::Size pattern = {});

// Radial distortion models, in the order they are tried.
enum class RadialModel { kK1 = 1, kK1K2 = 2, kK1K2K3 = 3 };

struct IntrinsicsFit {
  RadialModel model = RadialModel::kK1K2;
  double fx = 0, fy = 0, cx = 0, cy = 0, k1 = 0, k2 = 0, k3 = 0;
  // One standard deviation of fx, fy, cx, cy, k1, k2, k3 (0 for terms held
  // at 0). OpenCV 4.6 reports these about sqrt(2) too large (its residual
  // variance uses the point count, not the coordinate count); corrected here.
  double sigma[7] = {0, 0, 0, 0, 0, 0, 0};
  double rms_px = 0;                // RMS of the 2-D corner error, pixels
  std::vector<double> view_rms_px;  // per used view
  double holdout_rms_px = -1;       // leave-one-view-out RMS (choose_radial_model)
};

// Zhang calibration with `model`; square = checkerboard square size (any
// unit: only the extrinsics depend on it).
IntrinsicsFit calibrate_intrinsics(const ChessboardViews& views, double square, RadialModel model);

// Fits k1, then k1 k2, then k1 k2 k3, and keeps a further term only if it is
// significant (|k| > 3 sigma) and lowers the leave-one-view-out RMS by at
// least 1 % (model
// only what the data supports). `why` receives the evidence, one line per
// model.
IntrinsicsFit choose_radial_model(const ChessboardViews& views, double square, std::string* why);

}  // namespace lf::calib
