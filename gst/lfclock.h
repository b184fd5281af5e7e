// Capture and request schedules of the live sources on the pipeline clock
// (lfcamsrc, lfviewrequest): frame k at running time k * period + phase.
#pragma once

#include <gst/gst.h>

namespace lfgst {

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

}  // namespace lfgst
