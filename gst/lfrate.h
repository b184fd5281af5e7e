// Request rate limit (input from the network is bounded in rate): a token
// bucket holding up to `rate` tokens (a burst of one second's worth),
// refilled at `rate` per second; each admitted request takes its cost (one
// for a count of requests, its output pixels for a pixel budget). Not
// thread-safe: one streaming thread uses it.
#pragma once

#include <gst/gst.h>

#include <algorithm>
#include <iterator>
#include <map>

namespace lfgst {

class TokenBucket {
 public:
  // True if a request of `cost` tokens may pass now (they are taken);
  // `rate` in tokens per second, 0: no limit. The bucket starts full; a
  // request costing more than `rate` never passes.
  bool take(double rate, gint64 now_us = g_get_monotonic_time(), double cost = 1) {
    if (rate <= 0) return true;
    tokens_ =
        refilled_us_ < 0 ? rate : std::min(rate, tokens_ + rate * (now_us - refilled_us_) / 1e6);
    refilled_us_ = now_us;
    if (tokens_ < cost) return false;
    tokens_ -= cost;
    return true;
  }

 private:
  double tokens_ = 0;
  gint64 refilled_us_ = -1;
};

// The request rate limit per viewer: each viewer id has its own bucket, so
// one viewer's flood spends its own tokens and never another's (before, one
// bucket for all viewers: a flood took the real viewer's requests with it).
// At most kViewers ids have buckets of their own (ids idle for kIdleUs
// give theirs up); requests of any further id share one more bucket, so ids
// a peer makes up allocate nothing and get no fresh tokens. Not
// thread-safe: one streaming thread uses it.
class ViewerBuckets {
 public:
  static constexpr size_t kViewers = 64;
  static constexpr gint64 kIdleUs = 10 * G_USEC_PER_SEC;
  bool take(guint32 viewer, double rate, gint64 now_us = g_get_monotonic_time(), double cost = 1) {
    if (rate <= 0) return true;
    auto it = buckets_.find(viewer);
    if (it == buckets_.end()) {
      for (auto i = buckets_.begin(); buckets_.size() >= kViewers && i != buckets_.end();)
        i = now_us - i->second.used_us > kIdleUs ? buckets_.erase(i) : std::next(i);
      if (buckets_.size() >= kViewers) return overflow_.take(rate, now_us, cost);
      it = buckets_.emplace(viewer, Entry{}).first;
    }
    it->second.used_us = now_us;
    return it->second.bucket.take(rate, now_us, cost);
  }

 private:
  struct Entry {
    TokenBucket bucket;
    gint64 used_us = 0;
  };
  std::map<guint32, Entry> buckets_;
  TokenBucket overflow_;
};

// A camera host's limits on the view requests it answers, per viewer
// (lffragment's max-pixels, max-rate and max-pixel-rate; lfarray keeps them
// once for all its cameras): the view's size (max_pixels > 0), requests a
// second, and live, output pixels a second (a non-live pipeline renders
// every request). One per element that admits
// requests; not thread-safe.
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
// `host`: lfarray's limits kept once for all its cameras on one request
// thread (each of 64 lffragments deciding alone could drop a request in
// some cameras and not in others, and a non-live compositor's pads out of
// step hold the request thread for ever).
void limit_requests(GstPad* pad, GstElement* host, double rate, double pixel_rate, bool live);

// The default pixel budget per viewer (lffragment max-pixel-rate): a
// 1920x1080 view 60 times a second (a 3840x2160 view 15 times).
constexpr double kDefaultMaxPixelRate = 1920.0 * 1080 * 60;

}  // namespace lfgst
