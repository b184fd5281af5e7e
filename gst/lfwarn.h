// Bounded warnings for input from the network: a hostile peer sending bad
// data at a high rate must not flood the bus. At most kBurst element warnings
// per second per limiter; the others go to the debug log and are counted in
// the next warning.
#pragma once

#include <gst/gst.h>

namespace lfgst {

class WarnLimiter {
 public:
  WarnLimiter() { g_mutex_init(&m_); }
  ~WarnLimiter() { g_mutex_clear(&m_); }
  WarnLimiter(const WarnLimiter&) = delete;
  WarnLimiter& operator=(const WarnLimiter&) = delete;
  // True when a warning may be posted now; `suppressed` receives how many
  // were held back since the last one.
  static constexpr int kBurst = 5;
  bool allow(guint64* suppressed) {
    const gint64 now = g_get_monotonic_time();
    g_mutex_lock(&m_);
    if (window_ < 0 || now - window_ >= G_USEC_PER_SEC) window_ = now, count_ = 0;
    const bool ok = count_ < kBurst;
    if (ok) {
      ++count_;
      *suppressed = held_;
      held_ = 0;
    } else {
      ++held_;
    }
    g_mutex_unlock(&m_);
    return ok;
  }

 private:
  GMutex m_;
  gint64 window_ = -1;  // start of the current one-second window
  int count_ = 0;       // warnings posted in it
  guint64 held_ = 0;
};

}  // namespace lfgst

// GST_ELEMENT_WARNING through a WarnLimiter; the debug text is a printf
// format with at least one argument.
#define LF_ELEMENT_WARNING_LIMITED(el, limiter, domain, code, text, fmt, ...)          \
  G_STMT_START {                                                                       \
    guint64 lf_suppressed_ = 0;                                                        \
    if ((limiter).allow(&lf_suppressed_))                                              \
      GST_ELEMENT_WARNING(el, domain, code, text,                                      \
                          (fmt " (%" G_GUINT64_FORMAT " similar warnings suppressed)", \
                           __VA_ARGS__, lf_suppressed_));                              \
    else                                                                               \
      GST_DEBUG_OBJECT(el, fmt, __VA_ARGS__);                                          \
  }                                                                                    \
  G_STMT_END
