// A compositor's sink pads as fragments arrive, before GstAggregator queues
// them (pad probes on each sink pad's streaming thread):
//  * tracing (LF_TRACE, gst/lftrace.h): "fragment-in" at arrival;
//  * decoding on arrival: a JPEG fragment is decoded on the streaming
//    thread that brings it (the camera branch's in process, the RTP
//    receiver's across machines) into a raw fragment buffer, sealed here
//    (gst/lfmeta.h), so fragments of different pads decode in parallel and
//    while others are still on their way, not one after another on the
//    aggregate thread once the last has come. Only fragments the aggregate
//    thread would composite (what it last published: its viewer, inside the
//    sequence window, at most the view's area), one fragment per buffer or
//    per part of a bundle (gst/lfbundle.h);
//    everything else, and a fragment that does not parse, goes on unchanged
//    (the aggregate thread reports it).
#pragma once

#include <gst/gst.h>

#include <atomic>
#include <cstdint>

namespace lfgst {

class ArrivalDecoder {
 public:
  // Adds the probes to a new sink pad: tracing first (when enabled), then
  // decoding. The decoder outlives the pad's streaming.
  void install(GstPad* pad);
  // What the aggregate thread accepts now: fragments of outputs of
  // `view_pixels` (0: not known yet, nothing decoded), of viewer `viewer`
  // (-1: not known yet) and, in stereo, viewer + 1, with sequences after
  // `after` (lf::RequestWindow::inside; -1: none emitted yet).
  void publish(uint64_t view_pixels, int64_t viewer, bool stereo, int64_t after);
  // Nothing is decoded on arrival until published again (the element stops).
  void stop() { pixels_ = 0; }
  // Whether `buf` was decoded on arrival, and how long it took (ns).
  static bool decoded(GstBuffer* buf, gint64* decode_ns);

 private:
  static GstPadProbeReturn decode(GstPad* pad, GstPadProbeInfo* info, gpointer self);
  // A JPEG fragment's bytes that the aggregate thread would composite,
  // decoded into a new memory in the raw wire format, sealed; null for
  // anything else (and for one that does not decode).
  GstMemory* decode_one(const guint8* data, gsize size, uint64_t limit) const;
  std::atomic<uint64_t> pixels_{0};
  std::atomic<int64_t> viewer_{-1};
  std::atomic<bool> stereo_{false};
  std::atomic<int64_t> after_{-1};
};

}  // namespace lfgst
