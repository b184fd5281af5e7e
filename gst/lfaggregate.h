// Helpers shared by the collection's aggregators (lfcompositor,
// lfpartialsum: GstAggregator subclasses that collect the fragments of each
// view request and emit it when complete or at its deadline).
#pragma once

#include <gst/base/gstaggregator.h>
#include <gst/gst.h>

namespace lfgst {

// The running time now on the element's clock, or GST_CLOCK_TIME_NONE
// without a clock.
inline GstClockTime running_now(GstElement* e) {
  GstClock* clock = gst_element_get_clock(e);
  if (!clock) return GST_CLOCK_TIME_NONE;
  const GstClockTime now = gst_clock_get_time(clock);
  gst_object_unref(clock);
  const GstClockTime base = gst_element_get_base_time(e);
  return now > base ? now - base : 0;
}

// How long after its request's time (its PTS as running time on `pad`)
// buffer `buf` is taken at running time `now` (running_now(), read once
// for all the buffers one aggregate() takes), ns; -1 without a time or a
// clock.
inline gint64 arrival_age(GstAggregatorPad* pad, GstBuffer* buf, GstClockTime now) {
  const GstClockTime rt =
      gst_segment_to_running_time(&pad->segment, GST_FORMAT_TIME, GST_BUFFER_PTS(buf));
  return GST_CLOCK_TIME_IS_VALID(rt) && GST_CLOCK_TIME_IS_VALID(now) ? GST_CLOCK_DIFF(rt, now) : -1;
}

// Whether any sink pad of the aggregator holds a queued buffer (takes the
// object lock; safe from get_next_time, unlike gst_aggregator_get_latency).
inline bool any_pad_queued(GstElement* e) {
  bool queued = false;
  GST_OBJECT_LOCK(e);
  for (GList* l = e->sinkpads; l && !queued; l = l->next)
    queued = gst_aggregator_pad_has_buffer(GST_AGGREGATOR_PAD(l->data));
  GST_OBJECT_UNLOCK(e);
  return queued;
}

// The sink pads, each with a reference of its own (free the list with
// g_list_free_full(list, gst_object_unref)), and their number.
inline GList* ref_sink_pads(GstElement* e, size_t* count = nullptr) {
  GST_OBJECT_LOCK(e);
  GList* pads = g_list_copy_deep(
      e->sinkpads,
      [](gconstpointer p, gpointer) -> gpointer { return gst_object_ref(const_cast<gpointer>(p)); },
      nullptr);
  if (count) *count = e->numsinkpads;
  GST_OBJECT_UNLOCK(e);
  return pads;
}

// Emits the requests of `pending` (an lf::PendingRequests) that are due, in
// order (complete ones; at its own deadline, `due(running_time)`, at the
// end of stream or over the cap, an incomplete one): `emit(key, request,
// complete)` for each, until one does not return GST_FLOW_OK. With `shed`
// (live), first drops the requests behind a newer complete one (the newest
// request wins; lf::PendingRequests::shed_stale). Then GST_FLOW_EOS when
// every pad is at its end and nothing waits.
template <class Pending, class Due, class Emit>
GstFlowReturn emit_due(Pending& pending, size_t expected, Due due, bool all_eos, bool shed,
                       Emit emit) {
  GstFlowReturn ret = GST_FLOW_OK;
  if (shed) pending.shed_stale(expected);
  bool complete = false;
  while (ret == GST_FLOW_OK && pending.front_ready(expected, due, all_eos, &complete)) {
    ret = emit(pending.front_key(), pending.front(), complete);
    pending.pop_front();
  }
  if (ret == GST_FLOW_OK && all_eos && pending.empty()) return GST_FLOW_EOS;
  return ret;
}

}  // namespace lfgst
