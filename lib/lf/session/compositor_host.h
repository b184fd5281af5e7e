// The compositor host's frames (Yang et al. 2002, Section 4.3: the
// fragments of a view request added into the output frame, renormalised by
// the accumulated weight): what it keeps of each camera's answer until the
// request leaves, and the frame it makes of them with its renderer, the
// two eyes of a stereo pair side by side, and where a request left
// incomplete (a missed deadline) has no weight, the last frame's pixels
// instead of black.
//
// Plain C++, no GStreamer: lfcompositor is the glue. Not thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "lf/render/fragment.h"
#include "lf/render/renderer.h"

namespace lf {

// A piece of a camera's answer kept until its request is composited: a
// fragment (raw pixels in place in what was received, or decoded into
// f.pixels), or an empty one whose drawing was left to the compositor.
struct ReceivedPiece {
  Fragment f;
  const uint8_t* raw_pixels = nullptr;  // in place, kept valid by `keep`
  std::shared_ptr<const void> keep;     // what holds raw_pixels (a mapped buffer), or null
  std::shared_ptr<const DeferredDrawing> deferred;
  const uint8_t* pixels() const { return raw_pixels ? raw_pixels : f.pixels.data(); }
};

class FrameCompositor {
 public:
  explicit FrameCompositor(std::unique_ptr<Renderer> renderer) : renderer_(std::move(renderer)) {}
  struct Result {
    const cv::Mat* frame = nullptr;                    // CV_8UC4, valid until the next composite()
    size_t filled = 0;                                 // pixels taken from the last frame
    std::vector<std::pair<int, std::string>> refused;  // (camera id, why) left out
  };
  // One request's frame from its pieces: width x height, or with `stereo`
  // 2 width x height, the pieces of viewer `left_viewer` on the left and
  // the others on the right. An incomplete request (`complete` false) takes
  // the last frame's pixels where no weight arrived. Pieces the renderer
  // refuses are left out and named. Throws what the renderer throws
  // (std::invalid_argument, std::runtime_error).
  Result composite(const std::vector<ReceivedPiece>& pieces, int width, int height, bool stereo,
                   uint32_t left_viewer, bool complete);
  Renderer& renderer() { return *renderer_; }

 private:
  std::unique_ptr<Renderer> renderer_;
  cv::Mat last_;       // the last frame (missing pixels come from it)
  cv::Mat frames_[2];  // the frames resolved into, in turn (one is last_): no allocation per frame
  int next_ = 0;
};

}  // namespace lf
