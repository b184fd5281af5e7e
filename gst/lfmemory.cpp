#include "lfmemory.h"

#include <glib.h>

#include <atomic>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace lfgst {

void trim_heap() {
#if defined(__GLIBC__)
  static std::atomic<gint64> last_us{0};
  const gint64 now = g_get_monotonic_time();
  gint64 last = last_us.load();
  if (now - last < G_USEC_PER_SEC || !last_us.compare_exchange_strong(last, now)) return;
  malloc_trim(0);
#endif
}

}  // namespace lfgst
