#include "lfcommon.h"

#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <sstream>

#include "lf/datasets.h"
#include "lf/rig_file.h"
#include "lf/rig_ops.h"

namespace lfgst {

std::shared_ptr<const lf::Rig> load_rig_cached(const std::string& path) {
  static std::mutex m;
  static std::map<std::string, std::shared_ptr<const lf::Rig>> cache;
  std::lock_guard<std::mutex> lock(m);
  auto it = cache.find(path);
  if (it != cache.end()) return it->second;
  auto rig = std::make_shared<const lf::Rig>(lf::load_rig_or_dataset(path));
  cache[path] = rig;
  return rig;
}

bool parse_vec3(const gchar* s, cv::Vec3d& out) {
  if (!s) return false;
  std::stringstream ss(s);
  std::string tok;
  int n = 0;
  while (std::getline(ss, tok, ',')) {
    if (n >= 3) return false;
    try {
      size_t used = 0;
      out[n] = std::stod(tok, &used);
      if (used != tok.size() || !std::isfinite(out[n])) return false;
    } catch (const std::exception&) {
      return false;
    }
    ++n;
  }
  return n == 3;
}

ClockWaiter::ClockWaiter() {
  g_mutex_init(&lock_);
}
ClockWaiter::~ClockWaiter() {
  g_mutex_clear(&lock_);
}

bool ClockWaiter::wait_until(GstElement* el, GstClockTime t) {
  GstClock* clock = gst_element_get_clock(el);
  if (!clock) return true;
  g_mutex_lock(&lock_);
  if (unlocked_) {
    g_mutex_unlock(&lock_);
    gst_object_unref(clock);
    return false;
  }
  id_ = gst_clock_new_single_shot_id(clock, gst_element_get_base_time(el) + t);
  g_mutex_unlock(&lock_);
  const GstClockReturn r = gst_clock_id_wait(id_, nullptr);
  g_mutex_lock(&lock_);
  gst_clock_id_unref(id_);
  id_ = nullptr;
  g_mutex_unlock(&lock_);
  gst_object_unref(clock);
  return r != GST_CLOCK_UNSCHEDULED;
}

guint64 first_current_tick(GstElement* el, guint64 frame, GstClockTime period, GstClockTime phase) {
  GstClock* clock = gst_element_get_clock(el);
  if (!clock || period == 0) {
    if (clock) gst_object_unref(clock);
    return frame;
  }
  const GstClockTime now = gst_clock_get_time(clock), base = gst_element_get_base_time(el);
  gst_object_unref(clock);
  if (now < base + phase) return frame;
  const GstClockTime rt = now - base - phase;
  if (frame * period + period >= rt) return frame;  // at most one period late
  return (rt + period - 1) / period;                // the next tick
}

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

void ClockWaiter::unlock() {
  g_mutex_lock(&lock_);
  unlocked_ = true;
  if (id_) gst_clock_id_unschedule(id_);
  g_mutex_unlock(&lock_);
}

void ClockWaiter::unlock_stop() {
  g_mutex_lock(&lock_);
  unlocked_ = false;
  g_mutex_unlock(&lock_);
}

static const GstMetaInfo* capture_meta_info() {
  static const GstMetaInfo* info = nullptr;
  static gsize once = 0;
  if (g_once_init_enter(&once)) {
    static const gchar* tags[] = {nullptr};
    info = gst_meta_register_custom("LfCaptureMeta", tags, nullptr, nullptr, nullptr);
    g_once_init_leave(&once, 1);
  }
  return info;
}

void add_capture_meta(GstBuffer* buf, int camera_id, guint64 capture_time) {
  capture_meta_info();
  GstCustomMeta* m = gst_buffer_add_custom_meta(buf, "LfCaptureMeta");
  if (!m) return;
  gst_structure_set(gst_custom_meta_get_structure(m), "camera-id", G_TYPE_INT, camera_id,
                    "capture-time", G_TYPE_UINT64, capture_time, nullptr);
}

bool read_capture_meta(GstBuffer* buf, int* camera_id, guint64* capture_time) {
  capture_meta_info();
  GstCustomMeta* m = gst_buffer_get_custom_meta(buf, "LfCaptureMeta");
  if (!m) return false;
  const GstStructure* s = gst_custom_meta_get_structure(m);
  return gst_structure_get_int(s, "camera-id", camera_id) &&
         gst_structure_get_uint64(s, "capture-time", capture_time);
}

}  // namespace lfgst
