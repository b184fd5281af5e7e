// lfcompositor's deadline, set as its GstAggregator latency: how long after
// a request's running time it is composited with whatever arrived (live).
// One frame period of the request rate (Yang et al. 2002, 4.3), or longer
// with adaptive-deadline when the fragments take longer to arrive
// (lf::ArrivalDeadline, lib/lf/session/compositor_host.h), unless the
// element's `latency` property is set (then it alone).
#pragma once

#include <gst/base/gstaggregator.h>

#include <atomic>

#include "lf/session/compositor_host.h"

namespace lfgst {

// The longest deadline adaptive-deadline sets, ns.
constexpr GstClockTime kMaxAdaptiveDeadline = 500 * GST_MSECOND;

class CompositorDeadline {
 public:
  // At start: no ages, no adaptive deadline.
  void reset();
  // The request rate's frame period (ns; from the caps), then apply().
  void set_period(GstAggregator* agg, GstClockTime period);
  // A fragment taken from `pad` at running time `now`, used or late
  // (aggregate thread): its age.
  void arrived(GstAggregatorPad* pad, GstBuffer* buf, GstClockTime now);
  // Live, with adaptive-deadline (aggregate thread): the deadline from the
  // ages when it changes (then applied), else 0.
  GstClockTime adapt(GstAggregator* agg);
  // Sets the aggregator's latency: the period or the adaptive deadline,
  // whichever is longer; none of its own when `latency` is set (any thread:
  // the property's notify handler).
  void apply(GstAggregator* agg) const;

 private:
  std::atomic<GstClockTime> period_{0}, adaptive_{0};
  lf::ArrivalDeadline ages_;  // aggregate thread
};

}  // namespace lfgst
