#include "lftrace.h"

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

}  // namespace lfgst
