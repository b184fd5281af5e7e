#include "lftrace.h"

#include <libdeflate.h>

#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <mutex>

namespace lfgst {

namespace {
struct TraceFile {
  std::mutex m;
  FILE* f = nullptr;
  TraceFile() {
    const char* path = std::getenv("LF_TRACE");
    if (path && *path) {
      f = std::fopen(path, "a");
      if (!f) g_warning("LF_TRACE: cannot open '%s' for appending; tracing is off", path);
    }
  }
  ~TraceFile() {
    if (f) std::fclose(f);
  }
};
TraceFile& trace_file() {
  static TraceFile t;
  return t;
}
}  // namespace

bool trace_enabled() {
  return trace_file().f != nullptr;
}

void trace(GstElement* el, const char* event, guint viewer, guint64 sequence, gint camera, gint64 a,
           gint64 b, gint64 c) {
  TraceFile& t = trace_file();
  if (!t.f) return;
  GstClock* clock = gst_element_get_clock(el);
  if (!clock) return;  // not playing: no shared time base
  const GstClockTime now = gst_clock_get_time(clock);
  gst_object_unref(clock);
  std::lock_guard<std::mutex> lock(t.m);
  std::fprintf(t.f,
               "%s %u %" G_GUINT64_FORMAT " %d %" G_GUINT64_FORMAT " %" G_GINT64_FORMAT
               " %" G_GINT64_FORMAT " %" G_GINT64_FORMAT "\n",
               event, viewer, sequence, camera, now, a, b, c);
  std::fflush(t.f);
}

void trace_frame(GstElement* el, guint viewer, guint64 sequence, gint64 fragments,
                 const guint8* rgba, gsize bytes, gint64 ns, gsize filled) {
  const uint32_t sum = libdeflate_crc32(0, rgba, bytes);
  trace(el, "composited", viewer, sequence, -1, fragments, static_cast<gint64>(sum), ns);
  if (filled) trace(el, "filled", viewer, sequence, -1, static_cast<gint64>(filled));
}

}  // namespace lfgst
