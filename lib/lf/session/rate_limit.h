// Rate limits on what peers ask for (input from the network is bounded in
// rate): token buckets, one per viewer. Used by the camera hosts (lffragment,
// lfarray: requests and output pixels a second), the compositor host
// (FrameBudget, compositor_host.h) and lf-web (control messages a second),
// so every limit in the project counts the same way.
//
// Plain C++, no GStreamer. Times are microseconds of a monotonic clock. Not
// thread-safe: one thread uses each.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <map>

namespace lf {

// A token bucket holding up to `rate` tokens (a burst of one second's
// worth), refilled at `rate` per second; each admitted request takes its
// cost (one for a count of requests, its output pixels for a pixel budget).
class TokenBucket {
 public:
  // True if a request of `cost` tokens may pass now (they are taken);
  // `rate` in tokens per second, 0: no limit. The bucket starts full; a
  // request costing more than `rate` never passes.
  bool take(double rate, int64_t now_us, double cost = 1) {
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
  int64_t refilled_us_ = -1;
};

// A token bucket per viewer: each viewer id has its own, so one viewer's
// flood spends its own tokens and never another's (one bucket for all
// viewers let a flood take the real viewer's requests with it). At most
// kViewers ids have buckets of their own (ids idle for kIdleUs give theirs
// up); requests of any further id share one more bucket, so ids a peer
// makes up allocate nothing and get no fresh tokens.
class ViewerBuckets {
 public:
  static constexpr size_t kViewers = 64;
  static constexpr int64_t kIdleUs = 10'000'000;
  bool take(uint32_t viewer, double rate, int64_t now_us, double cost = 1) {
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
    int64_t used_us = 0;
  };
  std::map<uint32_t, Entry> buckets_;
  TokenBucket overflow_;
};

}  // namespace lf
