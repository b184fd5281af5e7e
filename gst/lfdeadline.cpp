#include "lfdeadline.h"

#include <algorithm>

#include "lfaggregate.h"

namespace lfgst {

void CompositorDeadline::reset() {
  ages_ = lf::ArrivalDeadline{};
  adaptive_ = 0;
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
