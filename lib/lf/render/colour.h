// Per-camera colour correction (Yang et al. 2002, Section 4.4.3), applied to
// a camera's frames before they are warped into fragments: every pixel's
// colour c becomes A c + b (8-bit levels, saturating), with the camera's
// row-major 3x4 matrix [A | b] (lf::Camera::colour, identity by default;
// calib/colour.h estimates it). The matrix is written for RGB channel order.
#pragma once

#include <mutex>
#include <opencv2/core.hpp>
#include <vector>

#include "lf/geometry/rig.h"

namespace lf {

// Channel order of 4-channel 8-bit images: GStreamer frames are RGBA, OpenCV
// images (lf::load_images) BGRA.
enum class ChannelOrder { kRGBA, kBGRA };

// The corrected image (CV_8UC4). The fourth channel is kept, or set to 255
// when `opaque` (frames whose fourth channel is padding, RGBx). Returns
// `image` itself, not a copy, when there is nothing to do (identity matrix,
// not opaque). Throws std::invalid_argument unless image is CV_8UC4.
cv::Mat colour_correct(const cv::Matx34d& colour, const cv::Mat& image, ChannelOrder order,
                       bool opaque = false);

// A camera's current frame as it is warped: corrected (colour_correct, RGBA),
// the copy made once per frame however many requests the frame answers
// (lffragment). Thread-safe.
class CorrectedFrame {
 public:
  // `image`, the frame known by `key` (compared only: a new key is a new
  // frame), corrected by `cam`'s matrix and made opaque with `opaque`; the
  // last copy when the key is the last one's; `image` itself when the
  // camera has no correction and nothing is opaque.
  cv::Mat get(const Camera& cam, const void* key, const cv::Mat& image, bool opaque);

 private:
  std::mutex m_;
  const void* key_ = nullptr;
  cv::Mat copy_;
};

// Corrects, in place, the images of every camera of `rig` that has a
// correction (images[i] belongs to rig.cameras[i]).
void colour_correct_images(const Rig& rig, std::vector<cv::Mat>& images, ChannelOrder order);

}  // namespace lf
