// Capture and request schedules of the live sources on the pipeline clock
// (lfcamsrc, lfviewrequest): frame k at running time k * period + phase.
#pragma once

#include <gst/base/gstbasesrc.h>
#include <gst/gst.h>

#include <deque>
#include <functional>
#include <vector>

// A source's GstBaseSrc unlock / unlock_stop, when all it waits on is its
// priv->waiter (a ClockWaiter).
#define LF_DEFINE_SRC_UNLOCK(PREFIX, CAST)                \
  static gboolean PREFIX##_unlock(GstBaseSrc* src) {      \
    CAST(src)->priv->waiter.unlock();                     \
    return TRUE;                                          \
  }                                                       \
  static gboolean PREFIX##_unlock_stop(GstBaseSrc* src) { \
    CAST(src)->priv->waiter.unlock_stop();                \
    return TRUE;                                          \
  }

namespace lfgst {

// Waits on the pipeline clock for a live source's schedule, or for
// something another thread does; unlock() interrupts a wait (GstBaseSrc
// unlock/unlock_stop).
class ClockWaiter {
 public:
  ClockWaiter();
  ~ClockWaiter();
  // Waits until running time `t` on `el`'s clock (returns at once without a
  // clock). false if interrupted (flushing).
  bool wait_until(GstElement* el, GstClockTime t);
  // Waits until `done()` holds, at most `timeout_us` (monotonic time):
  // `done` is checked at once and after each notify(), under the waiter's
  // lock (it may take the caller's own locks, which notify() must not be
  // called under). false if interrupted (flushing), else true (done or
  // timed out).
  bool wait_for(const std::function<bool()>& done, gint64 timeout_us);
  void notify();
  void unlock();
  void unlock_stop();

 private:
  GMutex lock_;
  GCond cond_;
  GstClockID id_ = nullptr;
  bool unlocked_ = false;
};

// A source's buffers of one tick beyond the first, given out by its next
// create() calls. Not a buffer list: GstBaseSrc 1.22 unrefs a NULL buffer
// when a state change meets a submitted list (gst_base_src_get_range), a
// CRITICAL on a busy machine. num-buffers keeps counting ticks.
class TickBacklog {
 public:
  TickBacklog() = default;
  TickBacklog(const TickBacklog&) = delete;
  TickBacklog& operator=(const TickBacklog&) = delete;
  ~TickBacklog();
  // The next buffer waiting, or null.
  GstBuffer* pop();
  // A tick's buffers (not empty): the first is returned, the others wait,
  // and `src`'s num-buffers grows by them.
  GstBuffer* push(GstBaseSrc* src, const std::vector<GstBuffer*>& bufs);

 private:
  std::deque<GstBuffer*> rest_;
};

// Live sources that start late (a host restarted under a shared base time):
// the first tick k >= `frame` whose time k * period + phase is at most one
// period in the past on `el`'s clock, so a late start skips ahead instead of
// emitting a burst of stale frames. `frame` itself without a clock.
guint64 first_current_tick(GstElement* el, guint64 frame, GstClockTime period, GstClockTime phase);

}  // namespace lfgst
