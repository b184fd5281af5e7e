/**
 * SECTION:element-lffragmentdemux
 * @title: lffragmentdemux
 *
 * Routes a fragment stream to one source pad per viewer, so several viewers
 * can share one set of cameras (Yang et al. 2002: "multiple viewers navigate
 * virtual cameras") and each viewer's lfcompositor gets only its own
 * fragments. Request a pad `src_%u` for viewer id `%u` (the `viewer-id` of
 * that viewer's lfviewrequest and lfcompositor; a stereo viewer N also uses
 * N + 1, its right eye). Each fragment goes to the pad of the viewer in its
 * header (lib/lf/wire/wire.h; read without decoding the payload) or, when no
 * such pad exists, nowhere: the viewer ids a peer writes only select among
 * the pads the application asked for, so a peer cannot make this element
 * allocate anything. Each pad gets the caps that came with its viewer's
 * fragments (the view size and request rate of that viewer's requests, as
 * lfrequestmux sends them), not every viewer's in turn: a compositor takes
 * its view size from them. A malformed buffer is dropped with a rate-limited
 * warning. Events from downstream (navigation, `lf-view`, `lf-focus`) go
 * upstream unchanged, towards the viewers' lfviewrequest.
 *
 * Viewers may come and go while the stream plays (lf-web adds and removes
 * one per browser): a pad is routed to only once it is whole, and a viewer
 * whose pad is unlinked or flushing (its branch stopping) loses its own
 * fragments, never the stream: the element returns FLUSHING upstream only
 * when its own sink pad flushes.
 *
 * The element pushes to one viewer's pad at a time: a viewer's branch that
 * blocks (its sink holding its first frame until the pipeline plays) stops
 * every viewer's fragments once its queue is full. Live, give each branch
 * a leaky queue, as in the example (lfrequestmux's docs say why).
 *
 * With a `tee` instead, every compositor receives and inspects every
 * viewer's fragments: the work per frame grows with the square of the
 * number of viewers.
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
#include <gst/base/gstflowcombiner.h>
#include <gst/gst.h>

#include <atomic>
#include <map>
#include <vector>

#include "lf/wire/wire.h"
#include "lfcaps.h"
#include "lfguard.h"
#include "lfprops.h"
#include "lfwarn.h"

GST_DEBUG_CATEGORY_STATIC(lf_fragment_demux_debug);
#define GST_CAT_DEFAULT lf_fragment_demux_debug

G_BEGIN_DECLS
#define LF_TYPE_FRAGMENT_DEMUX (lf_fragment_demux_get_type())
G_DECLARE_FINAL_TYPE(LfFragmentDemux, lf_fragment_demux, LF, FRAGMENT_DEMUX, GstElement)
G_END_DECLS

namespace {

struct Settings {  // read-only counts
  std::atomic<guint64> routed{0}, unrouted{0};
};

struct Priv {
  Settings settings;
  // viewer id -> its source pad (a reference); guarded by the object lock.
  std::map<guint, GstPad*> pads;
  GstFlowCombiner* combiner = gst_flow_combiner_new();  // guarded by the stream lock
  lfgst::WarnLimiter bad;
  ~Priv() {
    for (auto& [id, pad] : pads) gst_object_unref(pad);
    gst_flow_combiner_free(combiner);
  }
};

lfgst::Properties<Settings> props;
}  // namespace

struct _LfFragmentDemux {
  GstElement parent;
  GstPad* sinkpad;
  Priv* priv;
};

G_DEFINE_TYPE(LfFragmentDemux, lf_fragment_demux, GST_TYPE_ELEMENT)
GST_ELEMENT_REGISTER_DEFINE(lffragmentdemux, "lffragmentdemux", GST_RANK_NONE,
                            LF_TYPE_FRAGMENT_DEMUX)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_FRAGMENT_CAPS));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE(
    "src_%u", GST_PAD_SRC, GST_PAD_REQUEST, GST_STATIC_CAPS(LF_FRAGMENT_CAPS));

static GstFlowReturn lf_fragment_demux_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  LfFragmentDemux* self = LF_FRAGMENT_DEMUX(parent);
  Priv* p = self->priv;
  lf::FragmentHeader head;
  GError* err = nullptr;
  GstMapInfo map;
  gboolean ok = FALSE;
  if (gst_buffer_map(buf, &map, GST_MAP_READ)) {
    ok = lfgst::guard([&] { head = lf::peek_fragment_header(map.data, map.size); }, &err);
    gst_buffer_unmap(buf, &map);
  } else {
    g_set_error_literal(&err, lfgst::error_quark(), 0, "cannot map the buffer");
  }
  if (!ok) {
    LF_ELEMENT_WARNING_LIMITED(self, p->bad, STREAM, DEMUX, ("Dropping a malformed fragment"), "%s",
                               err->message);
    g_error_free(err);
    gst_buffer_unref(buf);
    return GST_FLOW_OK;
  }
  GST_OBJECT_LOCK(self);
  auto it = p->pads.find(head.viewer_id);
  GstPad* pad = it == p->pads.end() ? nullptr : GST_PAD(gst_object_ref(it->second));
  GST_OBJECT_UNLOCK(self);
  if (!pad) {
    GST_LOG_OBJECT(self, "fragment of viewer %u: no pad src_%u, dropped", head.viewer_id,
                   head.viewer_id);
    ++p->settings.unrouted;
    gst_buffer_unref(buf);
    return GST_FLOW_OK;
  }
  ++p->settings.routed;
  // The caps before a fragment are its request's (each camera sends its
  // request's caps before its answer, and a funnel forwards a pad's caps
  // when it switches): the viewer's own, its pad's when they differ.
  GstCaps* caps = gst_pad_get_current_caps(self->sinkpad);
  GstCaps* had = gst_pad_get_current_caps(pad);
  if (caps && (!had || !gst_caps_is_equal(caps, had)))
    gst_pad_push_event(pad, gst_event_new_caps(caps));
  for (GstCaps* c : {caps, had})
    if (c) gst_caps_unref(c);
  GstFlowReturn ret = gst_pad_push(pad, buf);
  // A viewer's pad that is flushing is that viewer's branch stopping (or not
  // yet playing): its fragments go nowhere, as if unlinked. FLUSHING from
  // one pad, combined as GStreamer's demuxers do, stopped the cameras' stream
  // for every viewer for good (a flush of the whole stream reaches this
  // element's sink pad, which then refuses the push itself).
  if (ret == GST_FLOW_FLUSHING) ret = GST_FLOW_NOT_LINKED;
  // Stream lock held (chain): the combiner is this thread's.
  const GstFlowReturn combined = gst_flow_combiner_update_pad_flow(p->combiner, pad, ret);
  gst_object_unref(pad);
  // One viewer gone (unlinked) must not stop the others.
  return combined == GST_FLOW_NOT_LINKED ? GST_FLOW_OK : combined;
}

// Sticky events (stream-start, caps, segment) the new pad needs before data.
static gboolean copy_sticky(GstPad*, GstEvent** event, gpointer srcpad) {
  gst_pad_store_sticky_event(GST_PAD(srcpad), *event);
  return TRUE;
}

// A new viewer pad is made whole (active, the stream's sticky events in
// place, in the flow combiner, on the element) before it is routed to, all
// under the sink pad's stream lock: no fragment, caps or segment reaches
// it half made. Before, the streaming thread could push to it while it was
// still inactive (FLUSHING) or before its stream-start.
static GstPad* lf_fragment_demux_request_new_pad(GstElement* element, GstPadTemplate* templ,
                                                 const gchar* name, const GstCaps*) {
  LfFragmentDemux* self = LF_FRAGMENT_DEMUX(element);
  Priv* p = self->priv;
  guint id = 0;
  if (name) {
    gchar* end = nullptr;
    const guint64 v = g_ascii_strtoull(name + 4, &end, 10);
    if (!g_str_has_prefix(name, "src_") || end == name + 4 || *end != '\0' || v > G_MAXUINT32) {
      GST_WARNING_OBJECT(self, "pad name '%s' is not src_<viewer id>", name);
      return nullptr;
    }
    id = static_cast<guint>(v);
  }
  GST_PAD_STREAM_LOCK(self->sinkpad);
  GST_OBJECT_LOCK(self);
  if (!name)
    while (p->pads.count(id)) ++id;
  const bool taken = p->pads.count(id) > 0;
  GST_OBJECT_UNLOCK(self);
  if (taken) {
    GST_PAD_STREAM_UNLOCK(self->sinkpad);
    GST_WARNING_OBJECT(self, "viewer %u has a pad already", id);
    return nullptr;
  }
  gchar* pad_name = g_strdup_printf("src_%u", id);
  GstPad* pad = gst_pad_new_from_template(templ, pad_name);
  g_free(pad_name);
  gst_pad_use_fixed_caps(pad);
  gst_pad_set_active(pad, TRUE);  // an inactive pad refuses sticky events
  gst_pad_sticky_events_foreach(self->sinkpad, copy_sticky, pad);
  gst_flow_combiner_add_pad(p->combiner, pad);
  gst_element_add_pad(element, pad);
  GST_OBJECT_LOCK(self);
  p->pads[id] = GST_PAD(gst_object_ref(pad));
  GST_OBJECT_UNLOCK(self);
  GST_PAD_STREAM_UNLOCK(self->sinkpad);
  return pad;
}

// Out of the routing first, then (under the stream lock) after the push in
// flight, if any, out of the combiner; only then deactivated.
static void lf_fragment_demux_release_pad(GstElement* element, GstPad* pad) {
  LfFragmentDemux* self = LF_FRAGMENT_DEMUX(element);
  Priv* p = self->priv;
  GST_OBJECT_LOCK(self);
  for (auto it = p->pads.begin(); it != p->pads.end(); ++it)
    if (it->second == pad) {
      gst_object_unref(it->second);
      p->pads.erase(it);
      break;
    }
  GST_OBJECT_UNLOCK(self);
  GST_PAD_STREAM_LOCK(self->sinkpad);
  gst_flow_combiner_remove_pad(p->combiner, pad);
  GST_PAD_STREAM_UNLOCK(self->sinkpad);
  gst_pad_set_active(pad, FALSE);
  gst_element_remove_pad(element, pad);
}

static gboolean lf_fragment_demux_sink_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  if (GST_EVENT_TYPE(event) == GST_EVENT_CAPS) {
    // A pad with caps gets new ones with its viewer's fragments (chain); one
    // without, now (caps go before the segment).
    LfFragmentDemux* self = LF_FRAGMENT_DEMUX(parent);
    std::vector<GstPad*> bare;
    GST_OBJECT_LOCK(self);
    for (auto& [id, src] : self->priv->pads)
      if (!gst_pad_has_current_caps(src)) bare.push_back(GST_PAD(gst_object_ref(src)));
    GST_OBJECT_UNLOCK(self);
    for (GstPad* src : bare) {
      gst_pad_push_event(src, gst_event_ref(event));
      gst_object_unref(src);
    }
    gst_event_unref(event);
    return TRUE;
  }
  if (GST_EVENT_TYPE(event) == GST_EVENT_FLUSH_STOP) {
    LfFragmentDemux* self = LF_FRAGMENT_DEMUX(parent);
    gst_flow_combiner_reset(self->priv->combiner);  // serialised: stream lock held
  }
  return gst_pad_event_default(pad, parent, event);  // to every source pad
}

static void lf_fragment_demux_property_set(GObject*, GParamSpec*, const GValue*) {}
LF_DEFINE_ELEMENT_GLUE(lf_fragment_demux, LF_FRAGMENT_DEMUX)

static void lf_fragment_demux_init(LfFragmentDemux* self) {
  self->priv = new Priv();
  self->sinkpad = gst_pad_new_from_static_template(&sink_template, "sink");
  gst_pad_set_chain_function(self->sinkpad, GST_DEBUG_FUNCPTR(lf_fragment_demux_chain));
  gst_pad_set_event_function(self->sinkpad, GST_DEBUG_FUNCPTR(lf_fragment_demux_sink_event));
  GST_PAD_SET_PROXY_CAPS(self->sinkpad);
  gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);
}

static void lf_fragment_demux_class_init(LfFragmentDemuxClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  oc->set_property = lf_fragment_demux_set_property;
  oc->get_property = lf_fragment_demux_get_property;
  oc->finalize = lf_fragment_demux_finalize;
  props.add(oc, &Settings::routed,
            lfgst::counter_spec("routed", "Routed", "Fragments pushed to a viewer's pad so far"));
  props.add(oc, &Settings::unrouted,
            lfgst::counter_spec("unrouted", "Unrouted",
                                "Fragments dropped so far because their viewer has no pad"));
  ec->request_new_pad = GST_DEBUG_FUNCPTR(lf_fragment_demux_request_new_pad);
  ec->release_pad = GST_DEBUG_FUNCPTR(lf_fragment_demux_release_pad);
  gst_element_class_add_static_pad_template(ec, &sink_template);
  gst_element_class_add_static_pad_template(ec, &src_template);
  gst_element_class_set_static_metadata(
      ec, "Light field fragment demuxer", "Demuxer/Network",
      "Routes fragments to one source pad per viewer (src_<viewer id>), so viewers sharing the "
      "cameras each get only their own (Yang et al. 2002)",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess viewer-id=3 num-buffers=30 ! "
      "lfcamerahost rig=../shared/data/stanford-chess ! lffragmentdemux name=d d.src_3 ! "
      "lfcompositor rig=../shared/data/stanford-chess viewer-id=3 ! videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "A rate-limited warning message for a malformed buffer; fragments of a viewer without a pad "
      "are counted in unrouted. Events from downstream go upstream unchanged.");
  GST_DEBUG_CATEGORY_INIT(lf_fragment_demux_debug, "lffragmentdemux", 0,
                          "light field fragment demuxer");
}
