#include "lf/render/colour.h"

#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

namespace lf {

namespace {
const cv::Matx34d kIdentity(1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0);
}  // namespace

cv::Mat colour_correct(const cv::Matx34d& colour, const cv::Mat& image, ChannelOrder order,
                       bool opaque) {
  if (image.type() != CV_8UC4) throw std::invalid_argument("colour_correct: image must be CV_8UC4");
  const bool correct = colour != kIdentity;
  if (!correct && !opaque) return image;
  // The matrix is for RGB: for BGR images, the same map with channels 0 and 2
  // swapped on both sides.
  cv::Matx34d m = colour;
  if (order == ChannelOrder::kBGRA) {
    const int p[3] = {2, 1, 0};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m(i, j) = colour(p[i], p[j]);
      m(i, 3) = colour(p[i], 3);
    }
  }
  cv::Mat rgb, out;
  cv::cvtColor(image, rgb, cv::COLOR_RGBA2RGB);      // drops the fourth channel
  if (correct) cv::transform(rgb, rgb, cv::Mat(m));  // saturating
  cv::cvtColor(rgb, out, cv::COLOR_RGB2RGBA);        // fourth channel 255
  if (!opaque) cv::mixChannels(image, out, std::vector<int>{3, 3});
  return out;
}

void colour_correct_images(const Rig& rig, std::vector<cv::Mat>& images, ChannelOrder order) {
  if (images.size() != rig.cameras.size())
    throw std::invalid_argument("colour_correct_images: " + std::to_string(images.size()) +
                                " images for " + std::to_string(rig.cameras.size()) + " cameras");
  for (size_t i = 0; i < images.size(); ++i)
    if (rig.cameras[i].has_colour_correction())
      images[i] = colour_correct(rig.cameras[i].colour, images[i], order);
}

cv::Mat CorrectedFrame::get(const Camera& cam, const void* key, const cv::Mat& image, bool opaque) {
  if (!opaque && !cam.has_colour_correction()) return image;
  std::lock_guard<std::mutex> l(m_);
  if (key_ != key || copy_.empty()) {
    copy_ = colour_correct(cam.colour, image, ChannelOrder::kRGBA, opaque);
    key_ = key;
  }
  return copy_;
}

}  // namespace lf
