#include "lfbundle.h"

#include <algorithm>
#include <iterator>

#include "lf/wire/wire.h"
#include "lfcaps.h"
#include "lfguard.h"
#include "lfmeta.h"

namespace lfgst {
namespace {
struct BundleMeta {
  GstMeta meta;
  guint32 sealed;
  GstBuffer* whole[kMaxBundleParts];  // a part's own buffer (held), or null
};
// It tells that the memories are this process's answers: never copied.
LocalMeta bundle_meta{"LfBundleMetaAPI", "LfBundleMeta", sizeof(BundleMeta),
                      [](GstMeta* m, gpointer, GstBuffer*) -> gboolean {
                        auto* b = reinterpret_cast<BundleMeta*>(m);
                        b->sealed = 0;
                        std::fill(std::begin(b->whole), std::end(b->whole), nullptr);
                        return TRUE;
                      },
                      [](GstMeta* m, GstBuffer*) {
                        for (GstBuffer* w : reinterpret_cast<BundleMeta*>(m)->whole)
                          if (w) gst_buffer_unref(w);
                      }};

BundleMeta* bundle_meta_of(GstBuffer* buf) {
  bundle_meta.registered();
  return reinterpret_cast<BundleMeta*>(gst_buffer_get_meta(buf, bundle_meta.api));
}
}  // namespace

void add_bundle_meta(GstBuffer* buf, guint32 sealed, GstBuffer* const* whole) {
  auto* m =
      reinterpret_cast<BundleMeta*>(gst_buffer_add_meta(buf, bundle_meta.registered(), nullptr));
  if (!m) return;
  m->sealed = sealed;
  for (guint k = 0; whole && k < kMaxBundleParts; ++k)
    m->whole[k] = whole[k] ? gst_buffer_ref(whole[k]) : nullptr;
}

bool is_bundle(GstBuffer* buf, guint32* sealed) {
  BundleMeta* m = bundle_meta_of(buf);
  if (m && sealed) *sealed = m->sealed;
  return m != nullptr;
}

GstBuffer* bundle_part(GstBuffer* bundle, guint k, guint32 sealed) {
  BundleMeta* m = k < kMaxBundleParts ? bundle_meta_of(bundle) : nullptr;
  if (m && m->whole[k]) return gst_buffer_ref(m->whole[k]);
  GstBuffer* part = gst_buffer_new();
  gst_buffer_append_memory(part, gst_buffer_get_memory(bundle, k));
  gst_buffer_copy_into(
      part, bundle, GstBufferCopyFlags(GST_BUFFER_COPY_FLAGS | GST_BUFFER_COPY_TIMESTAMPS), 0, -1);
  if (sealed & (1u << k)) add_sealed_meta(part);
  return part;
}

gint64 first_sequence(GstBuffer* buf, guint32* viewer) {
  if (gst_buffer_n_memory(buf) == 0) return -1;
  gint64 seq = -1;
  GstMapInfo map;
  // A bundle's first memory only; any other buffer whole.
  const bool bundle = is_bundle(buf, nullptr);
  GstMemory* mem = bundle ? gst_buffer_peek_memory(buf, 0) : nullptr;
  if (bundle ? !gst_memory_map(mem, &map, GST_MAP_READ) : !gst_buffer_map(buf, &map, GST_MAP_READ))
    return -1;
  guard(
      [&] {
        const lf::FragmentHeader h = lf::peek_fragment_header(map.data, map.size);
        seq = static_cast<gint64>(h.sequence);
        if (viewer) *viewer = h.viewer_id;
      },
      nullptr);
  if (bundle)
    gst_memory_unmap(mem, &map);
  else
    gst_buffer_unmap(buf, &map);
  return seq;
}

}  // namespace lfgst

struct _LfFragmentBundle {
  GstElement parent;
  GstPad* src;
  // The parts held (one request's), and for which request; taken on the
  // pushing thread under the object lock.
  GstBuffer* parts[lfgst::kMaxBundleParts];
  guint n;
  gint64 sequence;
  guint32 viewer;
  guint seen;  // parts of that request so far (held or already sent)
  guint eos;   // sink pads at EOS
};
G_DEFINE_TYPE(LfFragmentBundle, lf_fragment_bundle, GST_TYPE_ELEMENT)

static GstStaticPadTemplate bundle_sink = GST_STATIC_PAD_TEMPLATE(
    "sink_%u", GST_PAD_SINK, GST_PAD_REQUEST, GST_STATIC_CAPS(LF_FRAGMENT_CAPS));
static GstStaticPadTemplate bundle_src =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_FRAGMENT_CAPS));

// The parts held, as one buffer (a bundle when more than one); null when
// none. With the object lock held.
static GstBuffer* take_held(LfFragmentBundle* self) {
  if (self->n == 0) return nullptr;
  GstBuffer* out = self->parts[0];
  if (self->n > 1) {
    out = gst_buffer_new();
    guint32 sealed = 0;
    GstBuffer* whole[lfgst::kMaxBundleParts] = {};
    bool any_whole = false;
    for (guint k = 0; k < self->n; ++k) {
      gst_buffer_append_memory(out, gst_buffer_get_all_memory(self->parts[k]));
      if (lfgst::has_sealed_meta(self->parts[k])) sealed |= 1u << k;
      if (lfgst::deferred_of(self->parts[k])) any_whole = true, whole[k] = self->parts[k];
    }
    gst_buffer_copy_into(out, self->parts[0], GST_BUFFER_COPY_TIMESTAMPS, 0, -1);
    lfgst::add_bundle_meta(out, sealed, any_whole ? whole : nullptr);
    for (guint k = 0; k < self->n; ++k) gst_buffer_unref(self->parts[k]);
  }
  self->n = 0;
  return out;
}

static GstFlowReturn push_held(LfFragmentBundle* self) {
  GST_OBJECT_LOCK(self);
  GstBuffer* out = take_held(self);
  GST_OBJECT_UNLOCK(self);
  return out ? gst_pad_push(self->src, out) : GST_FLOW_OK;
}

static void drop_held(LfFragmentBundle* self) {
  GST_OBJECT_LOCK(self);
  for (guint k = 0; k < self->n; ++k) gst_buffer_unref(self->parts[k]);
  self->n = 0;
  GST_OBJECT_UNLOCK(self);
}

static GstFlowReturn bundle_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  auto* self = LF_FRAGMENT_BUNDLE(parent);
  guint32 viewer = 0;
  const gint64 seq = lfgst::first_sequence(buf, &viewer);
  // Alone: one that does not parse (the compositor reports it), or one of
  // several memories.
  if (seq < 0 || gst_buffer_n_memory(buf) != 1) {
    const GstFlowReturn ret = push_held(self);
    if (ret != GST_FLOW_OK) {
      gst_buffer_unref(buf);
      return ret;
    }
    return gst_pad_push(self->src, buf);
  }
  GST_OBJECT_LOCK(self);
  const bool other = seq != self->sequence || viewer != self->viewer;  // request
  GstBuffer* before = self->n && other ? take_held(self) : nullptr;
  if (other) self->seen = 0;
  self->parts[self->n++] = buf;
  self->sequence = seq, self->viewer = viewer;
  ++self->seen;
  const bool full = self->n == lfgst::kMaxBundleParts ||
                    self->seen >= static_cast<guint>(GST_ELEMENT(self)->numsinkpads);
  GstBuffer* now = full ? take_held(self) : nullptr;
  GST_OBJECT_UNLOCK(self);
  GstFlowReturn ret = before ? gst_pad_push(self->src, before) : GST_FLOW_OK;
  if (now) {
    if (ret == GST_FLOW_OK) return gst_pad_push(self->src, now);
    gst_buffer_unref(now);
  }
  return ret;
}

// Sticky events once (the cameras' caps and segments are the same); EOS
// when every sink pad has had it; anything serialized after what is held.
static gboolean bundle_sink_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  auto* self = LF_FRAGMENT_BUNDLE(parent);
  switch (GST_EVENT_TYPE(event)) {
    case GST_EVENT_STREAM_START:
    case GST_EVENT_CAPS:
    case GST_EVENT_SEGMENT: {
      GstEvent* had = gst_pad_get_sticky_event(self->src, GST_EVENT_TYPE(event), 0);
      bool same = had != nullptr;
      if (had && GST_EVENT_TYPE(event) == GST_EVENT_CAPS) {
        GstCaps *a = nullptr, *b = nullptr;
        gst_event_parse_caps(had, &a);
        gst_event_parse_caps(event, &b);
        same = gst_caps_is_equal(a, b);
      } else if (had && GST_EVENT_TYPE(event) == GST_EVENT_SEGMENT) {
        const GstSegment *a = nullptr, *b = nullptr;
        gst_event_parse_segment(had, &a);
        gst_event_parse_segment(event, &b);
        same = gst_segment_is_equal(a, b);
      }
      if (had) gst_event_unref(had);
      if (same) {
        gst_event_unref(event);
        return TRUE;
      }
      break;
    }
    case GST_EVENT_EOS: {
      push_held(self);
      GST_OBJECT_LOCK(self);
      const bool all = ++self->eos >= static_cast<guint>(GST_ELEMENT(self)->numsinkpads);
      GST_OBJECT_UNLOCK(self);
      if (!all) {
        gst_event_unref(event);
        return TRUE;
      }
      break;
    }
    case GST_EVENT_FLUSH_STOP:
      drop_held(self);
      GST_OBJECT_LOCK(self);
      self->eos = 0;
      GST_OBJECT_UNLOCK(self);
      break;
    default:
      if (GST_EVENT_IS_SERIALIZED(event)) push_held(self);
      break;
  }
  return gst_pad_event_default(pad, parent, event);
}

static GstPad* bundle_request_new_pad(GstElement* el, GstPadTemplate* templ, const gchar* name,
                                      const GstCaps*) {
  GstPad* pad = gst_pad_new_from_template(templ, name);
  gst_pad_set_chain_function(pad, bundle_chain);
  gst_pad_set_event_function(pad, bundle_sink_event);
  GST_PAD_SET_PROXY_CAPS(pad);
  GST_PAD_SET_PROXY_ALLOCATION(pad);
  gst_pad_set_active(pad, TRUE);
  gst_element_add_pad(el, pad);
  return pad;
}

static void bundle_release_pad(GstElement* el, GstPad* pad) {
  gst_pad_set_active(pad, FALSE);
  gst_element_remove_pad(el, pad);
}

static GstStateChangeReturn bundle_change_state(GstElement* el, GstStateChange t) {
  auto* self = LF_FRAGMENT_BUNDLE(el);
  if (t == GST_STATE_CHANGE_READY_TO_PAUSED) self->eos = 0;
  const GstStateChangeReturn ret =
      GST_ELEMENT_CLASS(lf_fragment_bundle_parent_class)->change_state(el, t);
  if (t == GST_STATE_CHANGE_PAUSED_TO_READY) drop_held(self);
  return ret;
}

static void lf_fragment_bundle_init(LfFragmentBundle* self) {
  self->sequence = -1;
  self->src = gst_pad_new_from_static_template(&bundle_src, "src");
  gst_element_add_pad(GST_ELEMENT(self), self->src);
}

static void lf_fragment_bundle_finalize(GObject* obj) {
  drop_held(LF_FRAGMENT_BUNDLE(obj));
  G_OBJECT_CLASS(lf_fragment_bundle_parent_class)->finalize(obj);
}

static void lf_fragment_bundle_class_init(LfFragmentBundleClass* klass) {
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  G_OBJECT_CLASS(klass)->finalize = lf_fragment_bundle_finalize;
  gst_element_class_add_static_pad_template(ec, &bundle_sink);
  gst_element_class_add_static_pad_template(ec, &bundle_src);
  ec->request_new_pad = bundle_request_new_pad;
  ec->release_pad = bundle_release_pad;
  ec->change_state = bundle_change_state;
  gst_element_class_set_static_metadata(
      ec, "Light field fragment bundle", "Filter/Network",
      "One buffer for a request thread's fragments of one request (internal to lfarray)",
      "lightfield-gst");
}
