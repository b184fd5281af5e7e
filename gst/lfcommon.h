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

// Live sources that start late (a host restarted under a shared base time):
// the first tick k >= `frame` whose time k * period + phase is at most one
// period in the past on `el`'s clock, so a late start skips ahead instead of
// emitting a burst of stale frames. `frame` itself without a clock.
guint64 first_current_tick(GstElement* el, guint64 frame, GstClockTime period, GstClockTime phase);

// Event trace for the latency and bandwidth measurements (tools/lf-trace).
// When the environment variable LF_TRACE names a file, the elements append
// one line per event to it:
//   EVENT VIEWER SEQUENCE CAMERA CLOCK_NS A B C
// CLOCK_NS is the element's pipeline clock time (the shared network clock
// under tools/lf-launch, so comparable across hosts); CAMERA is -1 for
// whole-request events. Events and their values A, B, C:
//   capture    lfcamsrc: frame emitted; SEQUENCE = frame number, A = scheduled
//              running time
//   issue      lfviewrequest: request sent; A = its running time
//   request-in lffragment: request received
//   warped     lffragment: fragment rendered; A = pixels
//   encoded    lffragment: serialized; A = bytes
//   fragment-in lfcompositor: fragment arrived at a sink pad; A = bytes,
//              B = capture time of its source frame (running time, ns)
//   decoded    lfcompositor: fragment parsed/decoded; A = ns spent
//   composited lfcompositor: output frame done; A = fragments, B = CRC-32
//              of the RGBA frame, C = ns spent compositing
bool trace_enabled();
void trace(GstElement* el, const char* event, guint viewer, guint64 sequence, gint camera,
           gint64 a = 0, gint64 b = 0, gint64 c = 0);

// Capture meta on camera frames (lfcamsrc): a GstCustomMeta "LfCaptureMeta"
// with fields camera-id (int) and capture-time (guint64, running time in ns).
// In-process only (metas do not cross the network; fragments carry the same
// in their header).
void add_capture_meta(GstBuffer* buf, int camera_id, guint64 capture_time);
bool read_capture_meta(GstBuffer* buf, int* camera_id, guint64* capture_time);

}  // namespace lfgst
