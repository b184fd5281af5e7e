#include "lfclock.h"

namespace lfgst {

ClockWaiter::ClockWaiter() {
  g_mutex_init(&lock_);
  g_cond_init(&cond_);
}
ClockWaiter::~ClockWaiter() {
  g_mutex_clear(&lock_);
  g_cond_clear(&cond_);
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

bool ClockWaiter::wait_for(const std::function<bool()>& done, gint64 timeout_us) {
  const gint64 until = g_get_monotonic_time() + timeout_us;
  g_mutex_lock(&lock_);
  while (!unlocked_ && !done())
    if (!g_cond_wait_until(&cond_, &lock_, until)) break;
  const bool ok = !unlocked_;
  g_mutex_unlock(&lock_);
  return ok;
}

void ClockWaiter::notify() {
  g_mutex_lock(&lock_);
  g_cond_broadcast(&cond_);
  g_mutex_unlock(&lock_);
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
  g_cond_broadcast(&cond_);
  g_mutex_unlock(&lock_);
}

void ClockWaiter::unlock_stop() {
  g_mutex_lock(&lock_);
  unlocked_ = false;
  g_mutex_unlock(&lock_);
}

TickBacklog::~TickBacklog() {
  for (GstBuffer* b : rest_) gst_buffer_unref(b);
}

GstBuffer* TickBacklog::pop() {
  if (rest_.empty()) return nullptr;
  GstBuffer* b = rest_.front();
  rest_.pop_front();
  return b;
}

GstBuffer* TickBacklog::push(GstBaseSrc* src, const std::vector<GstBuffer*>& bufs) {
  rest_.insert(rest_.end(), bufs.begin() + 1, bufs.end());
  if (bufs.size() > 1) {
    g_mutex_lock(&src->live_lock);  // the base class reads it under this lock
    if (src->num_buffers_left >= 0) src->num_buffers_left += static_cast<gint>(bufs.size() - 1);
    g_mutex_unlock(&src->live_lock);
  }
  return bufs[0];
}

}  // namespace lfgst
