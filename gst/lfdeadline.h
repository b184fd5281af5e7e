// lfcompositor's deadline, set as its GstAggregator latency: how long after
// a request's running time it is composited with whatever arrived (live).
// One frame period of the request rate (Yang et al. 2002, 4.3), or longer
// with adaptive-deadline when the fragments take longer to arrive
// (lf::ArrivalDeadline, lib/lf/session/compositor_host.h), unless the
// element's `latency` property is set (then it alone).
#pragma once

#include <gst/base/gstaggregator.h>

#include <atomic>
#include <mutex>

#include "lf/session/compositor_host.h"

namespace lfgst {

// The longest deadline adaptive-deadline sets, ns.
constexpr GstClockTime kMaxAdaptiveDeadline = 500 * GST_MSECOND;

class CompositorDeadline {
 public:
  // At start: no ages, no adaptive deadline, no run-ahead.
  void reset(GstAggregator* agg);
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
  // The output's pixels (from the caps, with the period), for the run-ahead.
  void set_view_pixels(guint64 pixels) { view_pixels_ = pixels; }
  // GstAggregatorClass::src_query through `parent`'s. Not live, every
  // request is waited for and throughput is what counts: a latency query
  // answered not live lets each sink pad hold the fragments of up to
  // kRunAhead requests (fewer for large views: about kRunAheadBytes of
  // fragments in all, taken as 3 fragment pixels of 4 bytes per output
  // pixel), so a request thread that runs ahead (a camera's fragment drawn
  // sooner) does not wait for the compositor fragment by fragment.
  // GstAggregator holds one buffer a pad unless its latency allows more:
  // this sets its min-upstream-latency to that many periods, unless the
  // user set it, and asks again (the aggregator takes it from a query). A
  // query answered live drops it. Undone by reset().
  gboolean src_query(GstAggregator* agg, GstQuery* query,
                     gboolean (*parent)(GstAggregator*, GstQuery*));
  static constexpr int kRunAhead = 16;
  static constexpr guint64 kRunAheadBytes = 128u << 20;

 private:
  std::atomic<GstClockTime> period_{0}, adaptive_{0};
  GstClockTime run_ahead_ = 0;  // the min-upstream-latency src_query() set (run_ahead_lock_)
  std::atomic<guint64> view_pixels_{0};
  std::mutex run_ahead_lock_;  // src_query() and reset()
  lf::ArrivalDeadline ages_;   // aggregate thread
};

}  // namespace lfgst
