#include "lf/quality/quality.h"

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/quality/qualityssim.hpp>
#include <stdexcept>

namespace lf {

namespace {
// The camera's image scaled to the view's height: its width and the
// columns cropped from each side (negative: padded).
std::pair<int, int> view_fit(const Camera& cam, int width, int height) {
  const double s = static_cast<double>(height) / cam.height;
  const double sw = cam.width * s, crop = 0.5 * (sw - width);
  if (std::abs(sw - std::round(sw)) > 1e-9 || std::abs(crop - std::round(crop)) > 1e-9)
    throw std::invalid_argument("camera_view_image: " + std::to_string(width) + "x" +
                                std::to_string(height) + " is not a whole-pixel crop of camera " +
                                std::to_string(cam.id) + "'s image");
  return {static_cast<int>(std::lround(sw)), static_cast<int>(std::lround(crop))};
}
}  // namespace

cv::Mat camera_view_image(const Camera& cam, const cv::Mat& image, int width, int height) {
  const auto [sw, c] = view_fit(cam, width, height);
  cv::Mat scaled;
  cv::resize(image, scaled, cv::Size(sw, height), 0, 0, cv::INTER_AREA);
  cv::Mat out(height, width, image.type(), cv::Scalar::all(0));
  const int x0 = std::max(0, c), x1 = std::min(scaled.cols, c + width);
  if (x1 > x0) scaled.colRange(x0, x1).copyTo(out.colRange(x0 - c, x1 - c));
  return out;
}

cv::Rect camera_view_rect(const Camera& cam, int width, int height) {
  const auto [sw, c] = view_fit(cam, width, height);
  const int x0 = std::max(0, c), x1 = std::min(sw, c + width);
  return cv::Rect(x0 - c, 0, std::max(0, x1 - x0), height);
}

cv::Mat square_pixel_image(const Camera& cam, const cv::Mat& image, Camera* square) {
  const Intrinsics& k = cam.intrinsics;
  if (k.has_distortion())
    throw std::invalid_argument("square_pixel_image: camera " + std::to_string(cam.id) +
                                " has lens distortion");
  *square = cam;
  square->intrinsics.fx = k.fy;
  const double s = k.fy / k.fx;
  cv::Mat out;
  cv::warpAffine(image, out, cv::Matx23d(s, 0, k.cx * (1 - s), 0, 1, 0), image.size(),
                 cv::INTER_LANCZOS4);
  return out;
}

// ---------------------------------------------------------------------------
// Metrics

namespace {
cv::Mat colour(const cv::Mat& m, int border) {
  if (m.empty() || m.depth() != CV_8U) throw std::invalid_argument("metric: 8-bit image expected");
  const cv::Rect roi(border, border, m.cols - 2 * border, m.rows - 2 * border);
  if (roi.width <= 0 || roi.height <= 0) throw std::invalid_argument("metric: border too large");
  cv::Mat c = m(roi);
  if (c.channels() == 4) cv::cvtColor(c, c, cv::COLOR_BGRA2BGR);
  return c;
}
}  // namespace

double psnr(const cv::Mat& a, const cv::Mat& b, int border) {
  if (a.size() != b.size()) throw std::invalid_argument("psnr: image sizes differ");
  return cv::PSNR(colour(a, border), colour(b, border));
}

double ssim(const cv::Mat& a, const cv::Mat& b, int border) {
  if (a.size() != b.size()) throw std::invalid_argument("ssim: image sizes differ");
  const cv::Scalar s =
      cv::quality::QualitySSIM::compute(colour(a, border), colour(b, border), cv::noArray());
  return (s[0] + s[1] + s[2]) / 3.0;
}

}  // namespace lf
