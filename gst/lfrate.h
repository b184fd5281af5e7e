// Request rate limit (input from the network is bounded in rate): a token
// bucket holding up to `rate` tokens (a burst of one second's worth),
// refilled at `rate` per second; each admitted request takes one. Not
// thread-safe: one streaming thread uses it.
#pragma once

#include <glib.h>

#include <algorithm>

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

}  // namespace lfgst
