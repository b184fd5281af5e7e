/**
 * SECTION:element-lfrequestmux
 * @title: lfrequestmux
 *
 * Joins several viewers' view requests into the one stream a camera host
 * answers (Yang et al. 2002, Section 1: "multiple viewers navigate virtual
 * cameras" over one set of cameras), taking the viewers in turn, as a fair
 * `funnel`. Request a pad `sink_%u` per viewer (an `lfviewrequest`).
 *
 * Not live: one request of every viewer each round (a GstAggregator without
 * latency waits for every pad), so no viewer runs ahead of another.
 * Live: as soon as any viewer has a request (a viewer that sends none, a
 * browser connected and silent, holds no other's), every viewer's newest
 * three requests (older ones queued behind them are dropped and counted in
 * `dropped`), the viewers in turn, so one viewer's flood takes no other's
 * turn; the camera host's request queue (`lfcamerahost`) then serves the
 * viewers fairly by the pixels they ask for and sheds what it cannot serve.
 * (Only the newest went on before: a 640x480 viewer beside a 3840x2160
 * flood lost one request in five here while the flood held the cameras.)
 *
 * Where the viewers' fragments come back through one stream
 * (`lffragmentdemux` into one compositor per viewer), give each viewer's
 * branch a leaky queue (`queue leaky=downstream`), as below: at start a
 * viewer's sink holds its first frame until the pipeline plays, which waits
 * for every sink's first frame, and a plain queue behind it fills and stops
 * the shared stream before the other viewer's first frame (the pipeline
 * never started in 4 of about 430 runs of the example with plain queues,
 * live, 64 cameras on 2 cores; docs/steering.md). Not live, every fragment
 * counts and the queues cannot leak; the viewers keep in step (one request
 * of each a round), and 220 runs of the example without is-live and with
 * plain queues all ended, 50 of them beside two busy loops (2026-11-30).
 *
 * Viewers may come and go while playing (lf-web adds and removes one per
 * browser): request and release pads as the viewers do.
 *
 * Caps (width, height and frame rate of the viewer's view) go downstream
 * with each viewer's requests when they differ from the last viewer's, as
 * `funnel` forwards sticky events. Events from downstream (navigation,
 * `lf-view`, `lf-focus`) go to every viewer, as through `funnel`.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfrequestmux name=reqs ! lfcamerahost rig=rig.json is-live=true ! \
 *   lffragmentdemux name=d \
 *   lfviewrequest viewer-id=0 rig=rig.json is-live=true ! reqs. \
 *   lfviewrequest viewer-id=1 rig=rig.json orbit=0.5 is-live=true ! reqs. \
 *   d.src_0 ! queue leaky=downstream ! lfcompositor viewer-id=0 rig=rig.json ! videoconvert ! \
 *   autovideosink \
 *   d.src_1 ! queue leaky=downstream ! lfcompositor viewer-id=1 rig=rig.json ! videoconvert ! \
 *   autovideosink
 * ]|
 */
#include <gst/base/gstaggregator.h>
#include <gst/gst.h>

#include <atomic>
#include <deque>
#include <new>

#include "lfaggregate.h"
#include "lfcaps.h"
#include "lfprops.h"

GST_DEBUG_CATEGORY_STATIC(lf_request_mux_debug);
#define GST_CAT_DEFAULT lf_request_mux_debug

G_BEGIN_DECLS
#define LF_TYPE_REQUEST_MUX (lf_request_mux_get_type())
G_DECLARE_FINAL_TYPE(LfRequestMux, lf_request_mux, LF, REQUEST_MUX, GstAggregator)
G_END_DECLS

namespace {
struct Settings {  // read-only counts
  std::atomic<guint64> forwarded{0}, dropped{0};
};
lfgst::Properties<Settings> props;
// Live: requests of a viewer forwarded each round, its newest (the camera
// host's lfrequestqueue keeps up to 3 of a viewer whose requests another
// viewer's work held back, lib/lf/session/request_queue.h).
constexpr size_t kKept = 3;
}  // namespace

struct _LfRequestMux {
  GstAggregator parent;
  guint next = 0;           // the pad (by index) served first in the next round
  GstCaps* caps = nullptr;  // the caps sent downstream last (aggregate thread)
  Settings* settings;       // properties
};

G_DEFINE_TYPE(LfRequestMux, lf_request_mux, GST_TYPE_AGGREGATOR)
GST_ELEMENT_REGISTER_DEFINE(lfrequestmux, "lfrequestmux", GST_RANK_NONE, LF_TYPE_REQUEST_MUX)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink_%u", GST_PAD_SINK, GST_PAD_REQUEST, GST_STATIC_CAPS(LF_REQUEST_CAPS));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_REQUEST_CAPS));

// One request of `pad` downstream, after its caps when they differ from the
// last ones sent.
static GstFlowReturn forward(LfRequestMux* self, GstAggregatorPad* pad, GstBuffer* buf) {
  GstCaps* caps = gst_pad_get_current_caps(GST_PAD(pad));
  if (caps && (!self->caps || !gst_caps_is_equal(caps, self->caps))) {
    gst_aggregator_set_src_caps(GST_AGGREGATOR(self), caps);
    gst_caps_replace(&self->caps, caps);
  }
  if (caps) gst_caps_unref(caps);
  self->settings->forwarded++;
  return gst_aggregator_finish_buffer(GST_AGGREGATOR(self), buf);
}

static GstFlowReturn lf_request_mux_aggregate(GstAggregator* agg, gboolean) {
  LfRequestMux* self = LF_REQUEST_MUX(agg);
  const bool live = GST_CLOCK_TIME_IS_VALID(gst_aggregator_get_latency(agg));
  GST_OBJECT_LOCK(agg);
  GList* pads = g_list_copy_deep(
      GST_ELEMENT(agg)->sinkpads,
      [](gconstpointer p, gpointer) -> gpointer { return gst_object_ref(const_cast<gpointer>(p)); },
      nullptr);
  GST_OBJECT_UNLOCK(agg);
  const guint n = g_list_length(pads);
  GstFlowReturn ret = GST_FLOW_OK;
  bool all_eos = n > 0;
  // The viewers in turn, starting one further each round.
  for (guint k = 0; k < n && ret == GST_FLOW_OK; ++k) {
    auto* pad = GST_AGGREGATOR_PAD(g_list_nth_data(pads, (self->next + k) % n));
    // Live: the viewer's newest kKept requests go on, older ones are
    // dropped; the camera host's lfrequestqueue sheds what it cannot serve,
    // fairly between viewers. Not live: one request a round.
    std::deque<GstBuffer*> bufs;
    while (GstBuffer* b = (live || bufs.empty()) ? gst_aggregator_pad_pop_buffer(pad) : nullptr) {
      bufs.push_back(b);
      if (bufs.size() > kKept) {
        gst_buffer_unref(bufs.front());
        bufs.pop_front();
        self->settings->dropped++;
      }
    }
    for (GstBuffer* b : bufs)
      if (ret == GST_FLOW_OK)
        ret = forward(self, pad, b);
      else
        gst_buffer_unref(b);
    if (!gst_aggregator_pad_is_eos(pad)) all_eos = false;
  }
  self->next = n ? (self->next + 1) % n : 0;
  g_list_free_full(pads, gst_object_unref);
  if (ret == GST_FLOW_OK && all_eos) return GST_FLOW_EOS;
  return ret;
}

// When to aggregate without a request from every viewer. Live: at once
// (the time 0, passed) as soon as any viewer has a request queued: a viewer
// that sends none (a browser connected and silent, or gone quiet) must not
// hold the others' requests. GstAggregator without this waits, live or not,
// until every pad has a buffer (or is at its end): one silent viewer froze
// every other viewer's video. Not live the base class still waits for every
// pad (no latency: no timeout), so each round has one request of each viewer.
// (Called under the aggregator's source lock: any_pad_queued takes only the
// object and pad locks.)
static GstClockTime lf_request_mux_get_next_time(GstAggregator* agg) {
  return lfgst::any_pad_queued(GST_ELEMENT(agg)) ? 0 : GST_CLOCK_TIME_NONE;
}

// The source caps are each viewer's own, set by forward() with its
// requests. GstAggregator's own negotiation (at a reconfigure, as when a
// viewer's pad is linked while playing) would fixate the pad template and
// send caps without the view's size and rate: every compositor downstream
// then lacked its view size and refused the fragments (a viewer added to a
// playing pipeline got no frame).
static gboolean lf_request_mux_negotiate(GstAggregator*) {
  return TRUE;
}

static gboolean lf_request_mux_stop(GstAggregator* agg) {
  LfRequestMux* self = LF_REQUEST_MUX(agg);
  gst_caps_replace(&self->caps, nullptr);
  self->next = 0;
  return TRUE;
}

static void lf_request_mux_get_property(GObject* obj, guint id, GValue* v, GParamSpec* ps) {
  props.get(obj, *LF_REQUEST_MUX(obj)->settings, id, v, ps);
}

static void lf_request_mux_finalize(GObject* obj) {
  gst_caps_replace(&LF_REQUEST_MUX(obj)->caps, nullptr);
  delete LF_REQUEST_MUX(obj)->settings;
  G_OBJECT_CLASS(lf_request_mux_parent_class)->finalize(obj);
}

static void lf_request_mux_class_init(LfRequestMuxClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  GstAggregatorClass* ac = GST_AGGREGATOR_CLASS(klass);
  oc->get_property = lf_request_mux_get_property;
  oc->finalize = lf_request_mux_finalize;
  props.add(oc, &Settings::forwarded,
            lfgst::counter_spec("forwarded", "Forwarded", "View requests sent downstream so far"));
  props.add(oc, &Settings::dropped,
            lfgst::counter_spec("dropped", "Dropped",
                                "Live: view requests dropped because three newer ones of the "
                                "same viewer were queued behind them"));
  gst_element_class_add_static_pad_template_with_gtype(ec, &sink_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype(ec, &src_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_set_static_metadata(
      ec, "Light field view request mux", "Mixer",
      "Joins several viewers' view requests into one stream, the viewers in turn (a fair "
      "funnel; not live: one request of each viewer a round)",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfrequestmux name=m ! lfcamerahost rig=../shared/data/stanford-chess "
      "is-live=true ! lffragmentdemux name=d lfviewrequest rig=../shared/data/stanford-chess "
      "viewer-id=0 is-live=true num-buffers=30 ! m. lfviewrequest "
      "rig=../shared/data/stanford-chess viewer-id=1 orbit=0.5 is-live=true num-buffers=30 ! m. "
      "d.src_0 ! queue leaky=downstream ! lfcompositor rig=../shared/data/stanford-chess "
      "viewer-id=0 ! videoconvert ! autovideosink d.src_1 ! queue leaky=downstream ! "
      "lfcompositor rig=../shared/data/stanford-chess viewer-id=1 ! videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Events from downstream go upstream to every viewer's branch unchanged; requests dropped as "
      "stale (live) are counted in dropped.");
  ac->aggregate = lf_request_mux_aggregate;
  ac->stop = lf_request_mux_stop;
  ac->get_next_time = lf_request_mux_get_next_time;
  ac->negotiate = lf_request_mux_negotiate;
  GST_DEBUG_CATEGORY_INIT(lf_request_mux_debug, "lfrequestmux", 0, "light field view request mux");
}

static void lf_request_mux_init(LfRequestMux* self) {
  self->settings = new Settings();
}
