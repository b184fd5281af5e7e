// A camera host's request limits as GStreamer elements apply them: the
// view size, requests a second and output pixels a second, per viewer
// (token buckets of lib/lf/session/rate_limit.h), with the warnings. Not
// thread-safe: one streaming thread uses each.
#pragma once

#include <gst/gst.h>

#include "lf/session/rate_limit.h"

namespace lfgst {

// The buckets themselves are the core's (lib/lf/session/rate_limit.h).
using lf::TokenBucket;
using lf::ViewerBuckets;

// A camera host's limits on the view requests it answers, per viewer
// (lffragment's max-pixels, max-rate and max-pixel-rate; lfcamerahost and
// lfarray keep the rates once for all their cameras, limit_requests): the view's size (max_pixels >
// 0), requests a second, and live, output pixels a second (a non-live pipeline renders every
// request). One per element that admits requests; not thread-safe.
class RequestLimits {
 public:
  enum class Verdict { kAdmit, kTooLarge, kOverRate, kOverPixelRate };
  Verdict admit(guint32 viewer, double rate, double pixel_rate, double pixels, bool live,
                gint64 now_us = g_get_monotonic_time(), double max_pixels = 0) {
    if (max_pixels > 0 && pixels > max_pixels) return Verdict::kTooLarge;
    if (!rate_.take(viewer, rate, now_us)) return Verdict::kOverRate;
    if (live && !pixels_.take(viewer, pixel_rate, now_us, pixels)) return Verdict::kOverPixelRate;
    return Verdict::kAdmit;
  }

 private:
  ViewerBuckets rate_, pixels_;
};

// The viewer id of a view request buffer (lib/lf/wire/wire.h: "LFVR", then the
// viewer id at byte 8, big-endian as every integer there), or G_MAXUINT32
// when it is none (the parser drops it later).
inline guint32 request_viewer(const guint8* data, gsize size) {
  if (size < 12 || data[0] != 'L' || data[1] != 'F' || data[2] != 'V' || data[3] != 'R')
    return G_MAXUINT32;
  return static_cast<guint32>(data[8]) << 24 | static_cast<guint32>(data[9]) << 16 |
         static_cast<guint32>(data[10]) << 8 | static_cast<guint32>(data[11]);
}

// The output pixels (width x height) of a view request buffer (lib/lf/wire/wire.h:
// width and height as u16 at bytes 84 and 86), or 0 when it has none.
inline double request_pixels(const guint8* data, gsize size) {
  if (size < 88 || request_viewer(data, size) == G_MAXUINT32) return 0;
  const guint w = static_cast<guint>(data[84]) << 8 | data[85];
  const guint h = static_cast<guint>(data[86]) << 8 | data[87];
  return static_cast<double>(w) * h;
}

class WarnLimiter;

// RequestLimits::admit; a request it drops gets a rate-limited warning on
// `el` naming the limit (max-rate or max-pixel-rate) and the viewer.
// With max_pixels > 0, a larger view is dropped too, warned about on
// `too_large` (a limiter of its own).
bool admit_or_warn(GstElement* el, RequestLimits& limits, WarnLimiter& warned, guint32 viewer,
                   double rate, double pixel_rate, double pixels, bool live, double max_pixels = 0,
                   WarnLimiter* too_large = nullptr);

// Drops the view requests through `pad` beyond `rate` requests and
// (live) `pixel_rate` output pixels a second per viewer, warning on
// `host`: a camera host's limits (lfcamerahost, lfarray) kept once for
// all its cameras on the thread that brings the requests (each of 64
// lffragments deciding alone dropped a request in some cameras and not in
// others: a frame composited incomplete, and a non-live compositor's pads
// out of step hold the request thread for ever).
void limit_requests(GstPad* pad, GstElement* host, double rate, double pixel_rate, bool live);

// The default pixel budget per viewer (lffragment max-pixel-rate): a
// 1920x1080 view 60 times a second (a 3840x2160 view 15 times).
constexpr double kDefaultMaxPixelRate = 1920.0 * 1080 * 60;

}  // namespace lfgst
