#include "lf/synthetic.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <random>

namespace lf {

Rig synthetic_grid_rig(int rows, int cols, double spacing, int width, int height, double vfov_deg,
                       double jitter_deg, uint64_t seed) {
  Rig rig;
  rig.name = "synthetic-" + std::to_string(rows) + "x" + std::to_string(cols);
  rig.grid.rows = rows;
  rig.grid.cols = cols;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const double f = 0.5 * height / std::tan(0.5 * vfov_deg * CV_PI / 180.0);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) {
      Camera cam;
      cam.id = r * cols + c;
      cam.name = "r" + std::to_string(r) + "c" + std::to_string(c);
      cam.width = width;
      cam.height = height;
      cam.intrinsics.fx = cam.intrinsics.fy = f;
      cam.intrinsics.cx = 0.5 * (width - 1);
      cam.intrinsics.cy = 0.5 * (height - 1);
      cv::Matx33d R = cv::Matx33d::eye();
      if (jitter_deg > 0) {
        cv::Vec3d axis(uni(rng), uni(rng), uni(rng));
        axis /= cv::norm(axis);
        cv::Matx33d Rj;
        cv::Rodrigues(axis * (jitter_deg * CV_PI / 180.0 * std::abs(uni(rng))), Rj);
        R = Rj;
      }
      const cv::Vec3d C((c - 0.5 * (cols - 1)) * spacing, (r - 0.5 * (rows - 1)) * spacing, 0);
      cam.extrinsics = Extrinsics::from_center(R, C);
      rig.grid.cells.push_back(static_cast<int>(rig.cameras.size()));
      rig.cameras.push_back(cam);
    }
  rig.finalize();
  return rig;
}

cv::Vec3d texture_colour(double x, double y, double p) {
  const double k = 2 * CV_PI / p;
  const double a = std::sin(k * x) * std::cos(0.7 * k * y);
  const double b = std::sin(0.45 * k * (x + y) + 1.0);
  const double c = std::cos(0.3 * k * x - 0.55 * k * y);
  return {127.5 + 60 * a + 35 * c, 127.5 + 55 * b + 40 * a, 127.5 + 50 * c - 45 * b};
}

cv::Mat render_textured_plane(const Camera& cam, double depth, double period) {
  cv::Mat img(cam.height, cam.width, CV_8UC4, cv::Scalar(0, 0, 0, 255));
  const cv::Vec3d C = cam.center();
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const auto d = cam.unproject({double(x), double(y)});
      if (!d || std::abs((*d)[2]) < 1e-12) continue;
      const double t = (depth - C[2]) / (*d)[2];
      if (!(t > 0)) continue;
      const cv::Vec3d X = C + *d * t;
      const cv::Vec3d col = texture_colour(X[0], X[1], period);
      auto& px = img.at<cv::Vec4b>(y, x);
      for (int ch = 0; ch < 3; ++ch) px[ch] = cv::saturate_cast<uchar>(col[ch]);
    }
  return img;
}

}  // namespace lf
