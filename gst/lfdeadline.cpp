#include "lfdeadline.h"

#include <algorithm>

#include "lfaggregate.h"

namespace lfgst {

void CompositorDeadline::reset(GstAggregator* agg) {
  ages_ = lf::ArrivalDeadline{};
  adaptive_ = 0;
  std::lock_guard<std::mutex> lock(run_ahead_lock_);
  GstClockTime set = 0;
  g_object_get(agg, "min-upstream-latency", &set, nullptr);
  if (set != 0 && set == run_ahead_)
    g_object_set(agg, "min-upstream-latency", GstClockTime{0}, nullptr);
  run_ahead_ = 0;
}

gboolean CompositorDeadline::src_query(GstAggregator* agg, GstQuery* query,
                                       gboolean (*parent)(GstAggregator*, GstQuery*)) {
  gboolean ok = parent(agg, query), live = FALSE;
  if (!ok || GST_QUERY_TYPE(query) != GST_QUERY_LATENCY) return ok;
  gst_query_parse_latency(query, &live, nullptr, nullptr);
  const GstClockTime period = period_.load();
  const guint64 pixels = view_pixels_.load();
  GstClockTime want = 0;  // live, or the view not known yet: none
  if (!live && period > 0 && pixels > 0)
    want = period *
           std::clamp<guint64>(kRunAheadBytes / (12 * pixels), 1, static_cast<guint64>(kRunAhead));
  {
    std::lock_guard<std::mutex> lock(run_ahead_lock_);
    GstClockTime set = 0;
    g_object_get(agg, "min-upstream-latency", &set, nullptr);
    if (set == want || (set != 0 && set != run_ahead_)) return ok;  // done, or the user's
    run_ahead_ = want;
    g_object_set(agg, "min-upstream-latency", want, nullptr);
  }
  return parent(agg, query);  // again, with it (not under the lock: it asks upstream)
}

void CompositorDeadline::set_period(GstAggregator* agg, GstClockTime period) {
  period_ = period;
  apply(agg);
}

void CompositorDeadline::arrived(GstAggregatorPad* pad, GstBuffer* buf, GstClockTime now) {
  ages_.arrived(arrival_age(pad, buf, now));
}

GstClockTime CompositorDeadline::adapt(GstAggregator* agg) {
  const GstClockTime period = period_.load(), now = running_now(GST_ELEMENT(agg));
  if (period == 0 || !GST_CLOCK_TIME_IS_VALID(now)) return 0;
  const auto v = ages_.update(static_cast<int64_t>(now), static_cast<int64_t>(period),
                              static_cast<int64_t>(kMaxAdaptiveDeadline));
  if (!v) return 0;
  adaptive_ = static_cast<GstClockTime>(*v);
  apply(agg);
  return adaptive_;
}

void CompositorDeadline::apply(GstAggregator* agg) const {
  const GstClockTime period = period_.load();
  if (period == 0) return;
  GstClockTime user = 0;
  g_object_get(agg, "latency", &user, nullptr);
  const GstClockTime own = user > 0 ? 0 : std::max(period, adaptive_.load());
  gst_aggregator_set_latency(agg, own, own);
}

}  // namespace lfgst
