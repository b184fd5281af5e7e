#include "lf/quality/synthetic.h"

#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <stdexcept>

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

namespace {
// Stripes of width w about every pitch p, irregularly spaced (a regular
// grating would alias in a plane sweep: the picket-fence problem).
bool in_bar(double x, double w, double p) {
  const double s = std::abs(x + 0.3 * p * std::sin(x * 2 * CV_PI / (3.7 * p)));
  return std::fmod(s, p) < w;
}
}  // namespace

SyntheticScene SyntheticScene::for_rig(const Rig& rig) {
  SyntheticScene sc;
  const CameraPlane& P = rig.plane();
  sc.origin = P.origin, sc.u = P.u, sc.v = P.v, sc.normal = P.normal;
  const double s = rig.typical_spacing();
  sc.far_depth = 60 * s;
  sc.near_depth = 25 * s;
  sc.disc_radius = 5 * s;
  sc.orbit_radius = 4 * s;
  sc.far_period = 6 * s;
  sc.near_period = 1.5 * s;
  return sc;
}

cv::Vec3d SyntheticScene::disc_centre(double t) const {
  const double a = 2 * CV_PI * t / period_s;
  return origin + normal * near_depth + u * (orbit_radius * std::cos(a)) +
         v * (orbit_radius * std::sin(a));
}

cv::Mat SyntheticScene::render(const Camera& cam, double t, bool rgba) const {
  cv::Mat img(cam.height, cam.width, CV_8UC4, cv::Scalar(0, 0, 0, 255));
  const cv::Vec3d C = cam.center(), D0 = disc_centre(t);
  const double cn = (C - origin).dot(normal);
  cv::parallel_for_(cv::Range(0, cam.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y)
      for (int x = 0; x < cam.width; ++x) {
        const auto d = cam.unproject({double(x), double(y)});
        if (!d) continue;
        const double dn = d->dot(normal);
        if (!(dn > 1e-12)) continue;
        cv::Vec3d col;
        const double tn = (near_depth - cn) / dn;
        const cv::Vec3d Xn = C + *d * tn;
        const cv::Vec3d r = Xn - D0;
        if (tn > 0 && r.dot(r) <= disc_radius * disc_radius &&
            (bar_width <= 0 || in_bar(r.dot(u), bar_width, bar_pitch))) {
          const cv::Vec3d c = texture_colour(r.dot(u), r.dot(v), near_period);
          col = {255 - c[0], c[2], 0.5 * (c[1] + 255)};  // distinct from the background
        } else {
          const double tf = (far_depth - cn) / dn;
          if (!(tf > 0)) continue;
          const cv::Vec3d Xf = C + *d * tf - origin;
          col = texture_colour(Xf.dot(u), Xf.dot(v), far_period);
        }
        auto& px = img.at<cv::Vec4b>(y, x);
        for (int ch = 0; ch < 3; ++ch) px[rgba ? ch : 2 - ch] = cv::saturate_cast<uchar>(col[ch]);
      }
  });
  return img;
}

Rig write_synthetic_images(Rig rig, const std::string& dir, double t) {
  const SyntheticScene scene = SyntheticScene::for_rig(rig);
  const std::filesystem::path base = std::filesystem::absolute(dir);
  for (auto& c : rig.cameras) {
    cv::Mat bgr;
    cv::cvtColor(scene.render(c, t, /*rgba=*/false), bgr, cv::COLOR_BGRA2BGR);
    const std::string file = (base / (c.name + ".png")).string();
    if (!cv::imwrite(file, bgr)) throw std::runtime_error("cannot write " + file);
    c.image = file;
  }
  return rig;
}

cv::Mat with_sensor_noise(const cv::Mat& rgba, double sigma, int camera_id, uint64_t frame) {
  cv::RNG rng((static_cast<uint64_t>(camera_id) << 40) ^ frame ^ 0x9e3779b97f4a7c15ULL);
  cv::Mat noise(rgba.size(), CV_16SC4), noisy;
  rng.fill(noise, cv::RNG::NORMAL, cv::Scalar::all(0), cv::Scalar(sigma, sigma, sigma, 0));
  cv::add(rgba, noise, noisy, cv::noArray(), CV_8UC4);  // saturating
  return noisy;
}

}  // namespace lf
