// Request rate limit (input from the network is bounded in rate): a token
// bucket holding up to `rate` tokens (a burst of one second's worth),
// refilled at `rate` per second; each admitted request takes one. Not
// thread-safe: one streaming thread uses it.
#pragma once

#include <glib.h>

#include <algorithm>
#include <iterator>
#include <map>

namespace lfgst {

class TokenBucket {
 public:
  // True if a request may pass now (a token taken); `rate` in requests per
  // second, 0: no limit. The bucket starts full.
  bool take(double rate, gint64 now_us = g_get_monotonic_time()) {
    if (rate <= 0) return true;
    tokens_ =
        refilled_us_ < 0 ? rate : std::min(rate, tokens_ + rate * (now_us - refilled_us_) / 1e6);
    refilled_us_ = now_us;
    if (tokens_ < 1) return false;
    tokens_ -= 1;
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
  bool take(guint32 viewer, double rate, gint64 now_us = g_get_monotonic_time()) {
    if (rate <= 0) return true;
    auto it = buckets_.find(viewer);
    if (it == buckets_.end()) {
      for (auto i = buckets_.begin(); buckets_.size() >= kViewers && i != buckets_.end();)
        i = now_us - i->second.used_us > kIdleUs ? buckets_.erase(i) : std::next(i);
      if (buckets_.size() >= kViewers) return overflow_.take(rate, now_us);
      it = buckets_.emplace(viewer, Entry{}).first;
    }
    it->second.used_us = now_us;
    return it->second.bucket.take(rate, now_us);
  }

 private:
  struct Entry {
    TokenBucket bucket;
    gint64 used_us = 0;
  };
  std::map<guint32, Entry> buckets_;
  TokenBucket overflow_;
};

// The viewer id of a view request buffer (lib/lf/wire.h: "LFVR", then the
// viewer id at byte 8, big-endian as every integer there), or G_MAXUINT32
// when it is none (the parser drops it later).
inline guint32 request_viewer(const guint8* data, gsize size) {
  if (size < 12 || data[0] != 'L' || data[1] != 'F' || data[2] != 'V' || data[3] != 'R')
    return G_MAXUINT32;
  return static_cast<guint32>(data[8]) << 24 | static_cast<guint32>(data[9]) << 16 |
         static_cast<guint32>(data[10]) << 8 | static_cast<guint32>(data[11]);
}

}  // namespace lfgst
