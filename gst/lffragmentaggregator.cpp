#include "lffragmentaggregator.h"

#include <algorithm>

#include "lfaggregate.h"
#include "lfbundle.h"
#include "lfguard.h"
#include "lfprops.h"

G_DEFINE_ABSTRACT_TYPE(LfFragmentAggregator, lf_fragment_aggregator, GST_TYPE_AGGREGATOR)

gboolean lf_deadline_passed(const LfDeadline* d, GstClockTime running_time) {
  return d->timeout && (!d->live || !GST_CLOCK_TIME_IS_VALID(running_time) ||
                        !GST_CLOCK_TIME_IS_VALID(d->now) || d->now >= running_time + d->latency);
}

gboolean lf_fragment_aggregator_push_upstream(LfFragmentAggregator* self, GstEvent* event) {
  GList* pads = lfgst::ref_sink_pads(GST_ELEMENT(self));
  gboolean any = FALSE;
  for (GList* l = pads; l; l = l->next)
    any |= gst_pad_push_event(GST_PAD(l->data), gst_event_ref(event));
  g_list_free_full(pads, gst_object_unref);
  gst_event_unref(event);
  return any;
}

// LF_IDLE_RELEASE after the last output, in running time (none before one).
// On the source thread (aggregate, get_next_time), which sets the position.
static GstClockTime idle_deadline(LfFragmentAggregator* self) {
  const GstSegment* seg = &GST_AGGREGATOR_PAD(GST_AGGREGATOR(self)->srcpad)->segment;
  const GstClockTime rt = gst_segment_to_running_time(seg, GST_FORMAT_TIME, seg->position);
  return GST_CLOCK_TIME_IS_VALID(rt) ? rt + LF_IDLE_RELEASE : GST_CLOCK_TIME_NONE;
}

static GstFlowReturn lf_fragment_aggregator_aggregate(GstAggregator* agg, gboolean timeout) {
  LfFragmentAggregator* self = LF_FRAGMENT_AGGREGATOR(agg);
  LfFragmentAggregatorClass* klass = LF_FRAGMENT_AGGREGATOR_GET_CLASS(self);
  if (klass->begin) klass->begin(self);
  const GstClockTime latency = gst_aggregator_get_latency(agg);
  LfDeadline d{timeout, GST_CLOCK_TIME_IS_VALID(latency), GST_CLOCK_TIME_NONE, latency};
  const gsize batch = d.live ? std::max<gsize>(1, klass->live_batch(self)) : 1;
  GstFlowReturn ret = GST_FLOW_OK;
  GList* pads = lfgst::ref_sink_pads(GST_ELEMENT(agg));
  auto take = [&](GstAggregatorPad* pad) {
    GstBuffer* buf = gst_aggregator_pad_pop_buffer(pad);
    if (!buf) return false;
    lfgst::each_bundled(buf, [&](GstBuffer* part) {  // a bundle's parts one by one
      if (ret == GST_FLOW_OK) ret = klass->absorb(self, pad, part);
    });
    gst_buffer_unref(buf);
    return ret == GST_FLOW_OK;
  };
  for (GList* l = pads; l && ret == GST_FLOW_OK; l = l->next)
    for (gsize i = 0; i < batch && take(GST_AGGREGATOR_PAD(l->data)); ++i) {
    }
  if (timeout) d.now = lfgst::running_now(GST_ELEMENT(agg));
  guint64 rt = GST_CLOCK_TIME_NONE, due = 0;
  const lf::RequestTimes* requests = klass->requests(self);
  if (ret == GST_FLOW_OK && requests && requests->oldest(&rt, &due) && lf_deadline_passed(&d, rt))
    for (GList* l = pads; l && ret == GST_FLOW_OK; l = l->next) {
      GstAggregatorPad* pad = GST_AGGREGATOR_PAD(l->data);
      while (GstBuffer* peek = gst_aggregator_pad_peek_buffer(pad)) {
        const gint64 seq = lfgst::first_sequence(peek);  // -1: reported when taken
        gst_buffer_unref(peek);
        if (seq > static_cast<gint64>(due) || !take(pad)) break;
      }
    }
  gboolean all_eos = TRUE;
  for (GList* l = pads; l; l = l->next)
    if (!gst_aggregator_pad_is_eos(GST_AGGREGATOR_PAD(l->data))) all_eos = FALSE;
  g_list_free_full(pads, gst_object_unref);
  if (ret != GST_FLOW_OK) return ret;
  ret = klass->emit_due(self, &d, all_eos);
  if (!klass->release_idle || !requests || requests->earliest_running_time() != GST_CLOCK_TIME_NONE)
    return ret;
  const GstClockTime idle = all_eos ? 0 : idle_deadline(self);  // (not on every frame's path)
  if (all_eos ||
      (d.live && GST_CLOCK_TIME_IS_VALID(d.now) && GST_CLOCK_TIME_IS_VALID(idle) && d.now >= idle))
    klass->release_idle(self, TRUE);
  return ret;
}

static GstClockTime lf_fragment_aggregator_get_next_time(GstAggregator* agg) {
  // (gst_aggregator_get_latency() would deadlock here: the caller holds the
  // aggregator's source lock.)
  if (lfgst::any_pad_queued(GST_ELEMENT(agg))) return 0;
  LfFragmentAggregator* self = LF_FRAGMENT_AGGREGATOR(agg);
  LfFragmentAggregatorClass* klass = LF_FRAGMENT_AGGREGATOR_GET_CLASS(self);
  const lf::RequestTimes* requests = klass->requests(self);
  const GstClockTime next = requests ? requests->earliest_running_time() : GST_CLOCK_TIME_NONE;
  if (next == GST_CLOCK_TIME_NONE && klass->release_idle && klass->release_idle(self, FALSE))
    return idle_deadline(self);  // woken once, to free it
  return next;
}

static gboolean lf_fragment_aggregator_src_event(GstAggregator* agg, GstEvent* event) {
  if (lfgst::refuse_seek(GST_ELEMENT(agg), event)) {
    gst_event_unref(event);
    return FALSE;
  }
  const bool view_event =
      GST_EVENT_TYPE(event) == GST_EVENT_CUSTOM_UPSTREAM && gst_event_has_name(event, "lf-view");
  if (GST_EVENT_TYPE(event) != GST_EVENT_NAVIGATION && !view_event)
    return GST_AGGREGATOR_CLASS(lf_fragment_aggregator_parent_class)->src_event(agg, event);
  LfFragmentAggregator* self = LF_FRAGMENT_AGGREGATOR(agg);
  LfFragmentAggregatorClass* klass = LF_FRAGMENT_AGGREGATOR_GET_CLASS(self);
  if (klass->tag_upstream) event = klass->tag_upstream(self, event);
  return lf_fragment_aggregator_push_upstream(self, event);
}

static void lf_fragment_aggregator_init(LfFragmentAggregator*) {}

static void lf_fragment_aggregator_class_init(LfFragmentAggregatorClass* klass) {
  GstAggregatorClass* ac = GST_AGGREGATOR_CLASS(klass);
  ac->aggregate = lf_fragment_aggregator_aggregate;
  ac->get_next_time = lf_fragment_aggregator_get_next_time;
  ac->src_event = lf_fragment_aggregator_src_event;
}
