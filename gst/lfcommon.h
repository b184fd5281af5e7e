// Shared helpers of the lightfield GStreamer elements (thin wrappers over lib/).
#pragma once

#include <gst/gst.h>

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "lf/rig.h"

// Caps of the in-band formats (lib/lf/wire.h gives the byte layouts).
#define LF_FRAGMENT_CAPS "application/x-lf-fragment, encoding = (string) { raw, jpeg }"
#define LF_REQUEST_CAPS "application/x-lf-view-request"

namespace lfgst {

// Loads a rig file or dataset folder once per process (shared by all
// elements that name the same path). Throws std::exception on errors.
std::shared_ptr<const lf::Rig> load_rig_cached(const std::string& path);

// "x,y,z" -> vector; false on malformed input.
bool parse_vec3(const gchar* s, cv::Vec3d& out);

// Waits on the pipeline clock for a live source's schedule; unlock()
// interrupts a wait (GstBaseSrc unlock/unlock_stop).
class ClockWaiter {
 public:
  ClockWaiter();
  ~ClockWaiter();
  // Waits until running time `t` on `el`'s clock (returns at once without a
  // clock). false if interrupted (flushing).
  bool wait_until(GstElement* el, GstClockTime t);
  void unlock();
  void unlock_stop();

 private:
  GMutex lock_;
  GstClockID id_ = nullptr;
  bool unlocked_ = false;
};

// Capture meta on camera frames (lfcamsrc): a GstCustomMeta "LfCaptureMeta"
// with fields camera-id (int) and capture-time (guint64, running time in ns).
// In-process only (metas do not cross the network; fragments carry the same
// in their header).
void add_capture_meta(GstBuffer* buf, int camera_id, guint64 capture_time);
bool read_capture_meta(GstBuffer* buf, int* camera_id, guint64* capture_time);

}  // namespace lfgst
