// The raw video an adding element sends: frames composited as RGBA
// (cv::Mat, CV_8UC4) of the view's size, sent as the first of RGBA, RGBx,
// I420 that downstream takes at the view's size; or, as stock compositor
// follows a downstream size, at the size downstream asks for (nearest to
// the view's), scaled by GStreamer's converter. The rate is the viewer's
// request rate and cannot follow: a mismatch is an error naming both sides.
// Output buffers come from a pool of its own (a frame is too large for the
// allocator to reuse: each would be a fresh mapping, zeroed by the kernel
// page by page). Used on the aggregate thread only.
#pragma once

#include <gst/base/gstaggregator.h>
#include <gst/video/video.h>

#include <functional>
#include <opencv2/core.hpp>

#include "lfprops.h"

namespace lfgst {

// The view's size and the output rate of an adding element: the
// properties when set, else the fragment caps (the viewer's request size and
// rate), else for the rate 30/1; never what a fragment claims.
class ViewFormat {
 public:
  // The properties (0 and 0/1: from the caps).
  ViewFormat(int width, int height, Fraction rate) : width_(width), height_(height), rate_(rate) {}
  // Fragment caps on `el`'s pads: a view size outside 1..max_side is
  // refused with a warning message, a change logged. True when the rate
  // changed.
  bool take_caps(GstElement* el, const GstCaps* caps, int max_side);
  Fraction fps() const;
  // The size of one view; false if unknown.
  bool view_size(int* w, int* h) const;

 private:
  int width_, height_;
  Fraction rate_;
  Fraction caps_rate_{0, 1};
  int caps_width_ = 0, caps_height_ = 0;
};

class RawVideoOutput {
 public:
  RawVideoOutput() = default;
  RawVideoOutput(const RawVideoOutput&) = delete;
  RawVideoOutput& operator=(const RawVideoOutput&) = delete;
  ~RawVideoOutput();
  // Negotiates `agg`'s source pad for frames of width x height at `fps`,
  // unless done already for that size. False after posting an error
  // message on `agg` (downstream takes no such video).
  bool negotiate(GstAggregator* agg, int width, int height, Fraction fps);
  // Forgets the negotiation: the next negotiate() queries downstream again
  // (GstAggregator's negotiate vfunc, on a reconfigure).
  void renegotiate() { negotiated_ = false; }
  // A buffer of the negotiated video holding `rgba` (the negotiated frame size).
  GstBuffer* frame(const cv::Mat& rgba);
  // A buffer of the negotiated video made by `make`. Where `direct` and the
  // negotiated video is RGBA or RGBx of the composited size, make(&into,
  // &last) resolves the frame straight into the buffer (`into`: it mapped,
  // continuous CV_8UC4; `last`: the last frame sent, empty if none; a copy
  // of 8 MB a frame less at 1080p). Else make(nullptr, nullptr) returns a
  // frame of its own, copied as frame() does. The last frame stays
  // referenced, read-only, so that an incomplete request's missing pixels
  // can come from it (an element downstream that writes into frames copies
  // it, as it would behind a tee). What `make` throws is thrown after the
  // buffer is given back.
  using MakeFrame = std::function<const cv::Mat&(cv::Mat* into, const cv::Mat* last)>;
  GstBuffer* make_frame(bool direct, const MakeFrame& make);
  // Frees the pool's buffers and the last frame (the stream ended); frames
  // after it are allocated one by one until the next negotiation.
  void release() { drop_pool(); }

 private:
  void drop_pool();
  GstBuffer* acquire();
  void drop_last();
  // make_frame()'s direct path: maps a buffer as `into` and the last frame
  // as `last`; false, nothing mapped, where it cannot (scaled, I420, a
  // padded stride). end_frame() unmaps both and gives the buffer, kept as
  // the next frame's last with `keep`.
  bool begin_frame(cv::Mat* into, cv::Mat* last);
  GstBuffer* end_frame(bool keep);
  GstBuffer* last_ = nullptr;  // the last frame begin_frame() mapped (a reference)
  GstVideoFrame into_map_{}, last_map_{};
  bool last_mapped_ = false;
  GstBufferPool* pool_ = nullptr;
  GstVideoInfo out_{};
  int width_ = 0, height_ = 0;  // frames composited (scaled to out_ if it differs)
  bool negotiated_ = false;
  GstVideoConverter* convert_ = nullptr;  // when scaled or I420
};

}  // namespace lfgst
