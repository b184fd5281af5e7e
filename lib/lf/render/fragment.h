// Image fragments (Yang et al. 2002, Section 4.2.1: "a small rectangular
// patch with associated 2D coordinates ... tagged, so the compositor can
// determine to which virtual view and focal plane they belong"), their CPU
// model: the type and its consistency check. Rendering: lf/render/render.h;
// compositing: lf/render/composite.h; the wire format: lf/wire/wire.h.
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

namespace lf {

// Largest Fragment::weight_shift: sums up to 255 << 8 (an aperture that
// blends 256 full weights at a pixel, lf/geometry/view.h kMaxApertureScale).
constexpr int kMaxWeightShift = 8;
// Largest Fragment::cameras.
constexpr int kMaxSummedCameras = 4096;

struct Fragment {
  uint32_t viewer_id = 0;
  uint64_t sequence = 0;
  uint32_t camera_id = 0;
  int64_t capture_time_ns = -1;  // capture time of the source frame, ns (-1: unknown)
  // 0, or 1 for the second planes of a focal surface's two-plane tiles
  // (lf/geometry/view.h FocalSurface::second_of, lf/render/plan.h plan_fragment's layer).
  uint8_t layer = 0;
  // A partial sum (lf/render/composite.h sum_fragments: a camera host adds up its
  // own cameras' fragments before sending) holds the sums of `cameras`
  // cameras' premultiplied pixels, each stored as (sum + 2^(s-1)) >> s
  // with s = weight_shift, so that sums over 255 fit 8 bits; the compositor
  // adds pixel << s. A single camera's fragment: 1 and 0.
  uint16_t cameras = 1;
  uint8_t weight_shift = 0;
  int out_width = 0, out_height = 0;  // size of the output frame it belongs to
  cv::Rect rect;                      // bounding box in output pixels (empty: no contribution)
  // Per row of rect: [begin, end) in output x. Pixels are stored row after
  // row, (end - begin) * 4 bytes each.
  std::vector<std::array<uint16_t, 2>> spans;
  std::vector<uint8_t> pixels;

  bool empty() const { return rect.area() == 0; }
  size_t pixel_count() const { return pixels.size() / 4; }
};

// Checks a fragment's internal consistency (spans inside rect and frame,
// pixel count). Throws std::invalid_argument describing the first problem.
void check_fragment(const Fragment& f);

// The same checks for a fragment whose pixels live elsewhere (f.pixels is
// not read: a fragment parsed in place, lf/wire/wire.h); returns the number of
// pixels its spans carry (4 bytes each).
size_t check_fragment_geometry(const Fragment& f);

}  // namespace lf
