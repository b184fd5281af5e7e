// Image fragments (Yang et al. 2002, Section 4.2.1: "a small rectangular
// patch with associated 2D coordinates ... tagged, so the compositor can
// determine to which virtual view and focal plane they belong"), their CPU
// rendering and their compositing.
//
// Pixels are 8-bit, 4 channels, premultiplied by the aperture weight: the
// first three channels hold colour * w, the fourth holds alpha * w where alpha
// is the source's fourth channel (255 for opaque images; 0 marks unusable
// source pixels). Channel order is whatever the source images use (RGBA in the
// GStreamer elements, BGRA in the OpenCV tools); nothing depends on it.
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "lf/plan.h"

namespace lf {

struct Fragment {
  uint32_t viewer_id = 0;
  uint64_t sequence = 0;
  uint32_t camera_id = 0;
  int64_t capture_time_ns = -1;       // capture time of the source frame, ns (-1: unknown)
  int out_width = 0, out_height = 0;  // size of the output frame it belongs to
  cv::Rect rect;                      // bounding box in output pixels (empty: no contribution)
  // Per row of rect: [begin, end) in output x. Pixels are stored row after
  // row, (end - begin) * 4 bytes each.
  std::vector<std::array<uint16_t, 2>> spans;
  std::vector<uint8_t> pixels;

  bool empty() const { return rect.area() == 0; }
  size_t pixel_count() const { return pixels.size() / 4; }
};

// Renders a planned fragment from the camera's current image (CV_8UC4,
// camera.width x camera.height). Bilinear sampling with edge clamping within
// half a pixel of the border; samples outside, behind the camera, or where
// the camera's distortion cannot be evaluated get alpha 0. Lens distortion is
// applied to the sampling coordinates when the camera has any. No threads,
// no allocation beyond `out.pixels`. Throws std::invalid_argument on an image
// of the wrong size or type.
enum class Kernel { kBest, kScalar };
// kBest uses SSE2 where the build has it (x86-64; meson option simd); the
// scalar reference kernel gives bit-identical results (tested).
void render_fragment(const FragmentPlan& plan, const Camera& camera, const cv::Mat& image,
                     Fragment& out, Kernel kernel = Kernel::kBest);
bool simd_available();

// Additive compositor with renormalisation (Section 4.3: "It then adds the
// fragment into the frame buffer"). Accumulates premultiplied fragments and
// divides by the accumulated weight, so missing or partially invalid
// fragments do not darken the image.
class Compositor {
 public:
  void reset(int width, int height);
  // Adds a fragment. Throws std::invalid_argument if it does not fit the frame.
  void add(const Fragment& f);
  // Writes the normalised frame (CV_8UC4; alpha = 255 where any weight arrived,
  // 0 elsewhere, where colour is 0).
  void resolve(cv::Mat& out) const;
  // Accumulated weight (0..255 per full contribution) at a pixel.
  uint32_t weight_at(int x, int y) const { return acc_[(static_cast<size_t>(y) * w_ + x) * 4 + 3]; }
  int width() const { return w_; }
  int height() const { return h_; }

 private:
  int w_ = 0, h_ = 0;
  std::vector<uint32_t> acc_;
};

// Checks a fragment's internal consistency (spans inside rect and frame,
// pixel count). Throws std::invalid_argument describing the first problem.
void check_fragment(const Fragment& f);

}  // namespace lf
