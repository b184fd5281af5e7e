#include "lfclock.h"

namespace lfgst {

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

}  // namespace lfgst
