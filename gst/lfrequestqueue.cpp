/**
 * SECTION:element-lfrequestqueue
 * @title: lfrequestqueue
 *
 * A queue of view requests for a live camera host that sheds load instead
 * of queueing it (lib/lf/session/request_queue.h): for each viewer (its frame
 * requests, and apart from them its focus and surface probes) it keeps only
 * the requests within `max-age` of that viewer's newest (0: the newest
 * alone), at most 64 in all, and serves the viewers in turns weighted by
 * their requests' output pixels (the caps' width x height: fair queueing,
 * the viewer served least goes next), each one's oldest kept request
 * first, on a thread of its own (like `queue`). A camera host that cannot
 * keep the requested rate then answers each viewer's newest work instead
 * of working through a backlog, and a viewer that floods requests for
 * large views takes only its own share, never a viewer of small ones'.
 *
 * lfarray and lfcamerahost put one before their cameras when live. Requests
 * dropped are counted in `dropped`; caps (the view size and rate of the
 * viewer whose requests follow them) go downstream with the requests they
 * came before, end of stream after the queued requests, other serialized
 * events at once (each request carries its own view).
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=rig.json is-live=true ! lfrequestqueue ! \
 *   lfcamerahost rig=rig.json is-live=true ! lfcompositor rig=rig.json ! videoconvert ! \
 *   autovideosink
 * ]|
 */
#include <gst/gst.h>

#include <atomic>
#include <new>

#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/session/request_queue.h"
#include "lfcaps.h"
#include "lfprops.h"
#include "lfrate.h"

GST_DEBUG_CATEGORY_STATIC(lf_request_queue_debug);
#define GST_CAT_DEFAULT lf_request_queue_debug

G_BEGIN_DECLS
#define LF_TYPE_REQUEST_QUEUE (lf_request_queue_get_type())
G_DECLARE_FINAL_TYPE(LfRequestQueue, lf_request_queue, LF, REQUEST_QUEUE, GstElement)
G_END_DECLS

namespace {
struct Settings {
  guint64 max_age = 0;  // ns, under the object lock
  std::atomic<guint64> dropped{0};
};
lfgst::Properties<Settings> props;
constexpr guint64 kDefaultMaxAge = 0;
constexpr size_t kCapacity = 64;

// The queue's key of a request buffer: its viewer id, and whether it is a
// probe (a probe never displaces the viewer's frame requests, nor they it).
guint64 request_key(GstBuffer* buf) {
  guint8 head[20] = {};
  const gsize got = gst_buffer_extract(buf, 0, head, sizeof head);
  const guint32 viewer = lfgst::request_viewer(head, got);
  guint64 seq = 0;
  for (int i = 12; i < 20 && got >= 20; ++i) seq = seq << 8 | head[i];
  const bool probe = got >= 20 && (lf::is_focus_probe(seq) || lf::is_surface_probe(seq));
  return static_cast<guint64>(viewer) << 1 | (probe ? 1 : 0);
}

// A request's cost in the viewers' turns (lib/lf/session/request_queue.h):
// its view's output pixels, from the caps it came with (1 without them).
double request_cost(GstCaps* caps) {
  gint w = 0, h = 0;
  if (caps && gst_caps_get_size(caps) > 0) {
    const GstStructure* s = gst_caps_get_structure(caps, 0);
    if (!gst_structure_get_int(s, "width", &w) || !gst_structure_get_int(s, "height", &h)) w = 0;
  }
  return w > 0 && h > 0 ? static_cast<double>(w) * h : 1;
}

// A queued request and the caps it came with (its viewer's view size and
// rate: they go downstream before it when they differ from the last sent).
struct Queued {
  GstBuffer* buf;
  GstCaps* caps;  // or null
};
}  // namespace

struct _LfRequestQueue {
  GstElement parent;
  GstPad *sinkpad, *srcpad;
  GMutex lock;
  GCond cond;
  lf::RequestQueue<Queued>* queue;  // under lock
  bool flushing, eos;               // under lock
  GstFlowReturn last_ret;           // under lock: what the source pad got last
  Settings* settings;               // properties (max-age under the object lock)
};

G_DEFINE_TYPE(LfRequestQueue, lf_request_queue, GST_TYPE_ELEMENT)
GST_ELEMENT_REGISTER_DEFINE(lfrequestqueue, "lfrequestqueue", GST_RANK_NONE, LF_TYPE_REQUEST_QUEUE)

static GstStaticPadTemplate sink_template =
    GST_STATIC_PAD_TEMPLATE("sink", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_REQUEST_CAPS));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_REQUEST_CAPS));

static void release(const std::vector<Queued>& items) {
  for (const Queued& q : items) {
    gst_buffer_unref(q.buf);
    if (q.caps) gst_caps_unref(q.caps);
  }
}

// The source pad's thread: the next request in turn downstream, end of
// stream once the queue is empty after it.
static void lf_request_queue_loop(gpointer data) {
  LfRequestQueue* self = LF_REQUEST_QUEUE(data);
  g_mutex_lock(&self->lock);
  while (self->queue->empty() && !self->eos && !self->flushing)
    g_cond_wait(&self->cond, &self->lock);
  if (self->flushing) {
    g_mutex_unlock(&self->lock);
    gst_pad_pause_task(self->srcpad);
    return;
  }
  if (self->queue->empty()) {  // end of stream, everything sent
    g_mutex_unlock(&self->lock);
    gst_pad_push_event(self->srcpad, gst_event_new_eos());
    gst_pad_pause_task(self->srcpad);
    return;
  }
  const Queued q = self->queue->pop();
  g_mutex_unlock(&self->lock);
  GstCaps* sent = gst_pad_get_current_caps(self->srcpad);
  if (q.caps && (!sent || !gst_caps_is_equal(q.caps, sent)))
    gst_pad_push_event(self->srcpad, gst_event_new_caps(q.caps));
  if (sent) gst_caps_unref(sent);
  if (q.caps) gst_caps_unref(q.caps);
  const GstFlowReturn ret = gst_pad_push(self->srcpad, q.buf);
  g_mutex_lock(&self->lock);
  self->last_ret = ret;
  g_mutex_unlock(&self->lock);
  if (ret == GST_FLOW_OK || ret == GST_FLOW_NOT_LINKED) return;
  gst_pad_pause_task(self->srcpad);
  if (ret == GST_FLOW_EOS || ret <= GST_FLOW_NOT_NEGOTIATED) {
    if (ret != GST_FLOW_EOS) GST_ELEMENT_FLOW_ERROR(self, ret);
    gst_pad_push_event(self->srcpad, gst_event_new_eos());
  }
}

static GstFlowReturn lf_request_queue_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  LfRequestQueue* self = LF_REQUEST_QUEUE(parent);
  const guint64 key = request_key(buf);
  const guint64 time = GST_BUFFER_PTS_IS_VALID(buf)
                           ? GST_BUFFER_PTS(buf)
                           : static_cast<guint64>(g_get_monotonic_time()) * 1000;
  g_mutex_lock(&self->lock);
  if (self->flushing || self->eos) {
    const GstFlowReturn ret = self->flushing ? GST_FLOW_FLUSHING : GST_FLOW_EOS;
    g_mutex_unlock(&self->lock);
    gst_buffer_unref(buf);
    return ret;
  }
  const GstFlowReturn ret = self->last_ret;
  GstCaps* caps = gst_pad_get_current_caps(self->sinkpad);
  const std::vector<Queued> dropped = self->queue->push(key, time, {buf, caps}, request_cost(caps));
  g_cond_signal(&self->cond);
  g_mutex_unlock(&self->lock);
  if (!dropped.empty()) {
    self->settings->dropped += dropped.size();
    GST_LOG_OBJECT(self, "%zu stale requests dropped", dropped.size());
    release(dropped);
  }
  return ret == GST_FLOW_NOT_LINKED ? GST_FLOW_OK : ret;
}

static void lf_request_queue_start(LfRequestQueue* self) {
  GST_OBJECT_LOCK(self);
  const guint64 max_age = self->settings->max_age;
  GST_OBJECT_UNLOCK(self);
  g_mutex_lock(&self->lock);
  release(self->queue->clear());
  delete self->queue;
  self->queue = new lf::RequestQueue<Queued>(kCapacity, max_age);
  self->flushing = self->eos = false;
  self->last_ret = GST_FLOW_OK;
  g_mutex_unlock(&self->lock);
  gst_pad_start_task(self->srcpad, lf_request_queue_loop, self, nullptr);
}

static void lf_request_queue_stop(LfRequestQueue* self) {
  g_mutex_lock(&self->lock);
  self->flushing = true;
  self->last_ret = GST_FLOW_FLUSHING;
  g_cond_signal(&self->cond);
  g_mutex_unlock(&self->lock);
  gst_pad_stop_task(self->srcpad);
  g_mutex_lock(&self->lock);
  release(self->queue->clear());
  g_mutex_unlock(&self->lock);
}

static gboolean lf_request_queue_sink_event(GstPad* pad, GstObject* parent, GstEvent* ev) {
  LfRequestQueue* self = LF_REQUEST_QUEUE(parent);
  switch (GST_EVENT_TYPE(ev)) {
    case GST_EVENT_FLUSH_START: {
      const gboolean ok = gst_pad_push_event(self->srcpad, ev);
      g_mutex_lock(&self->lock);
      self->flushing = true;
      self->last_ret = GST_FLOW_FLUSHING;
      g_cond_signal(&self->cond);
      g_mutex_unlock(&self->lock);
      gst_pad_pause_task(self->srcpad);
      return ok;
    }
    case GST_EVENT_FLUSH_STOP: {
      const gboolean ok = gst_pad_push_event(self->srcpad, ev);
      lf_request_queue_start(self);  // (empties the queue)
      return ok;
    }
    case GST_EVENT_CAPS:  // with the requests after them (the loop), but the first at once
      if (gst_pad_has_current_caps(self->srcpad)) {
        gst_event_unref(ev);
        return TRUE;
      }
      return gst_pad_push_event(self->srcpad, ev);
    case GST_EVENT_EOS:  // after the queued requests (the source pad's thread)
      g_mutex_lock(&self->lock);
      self->eos = true;
      g_cond_signal(&self->cond);
      g_mutex_unlock(&self->lock);
      gst_event_unref(ev);
      return TRUE;
    default:
      return gst_pad_event_default(pad, parent, ev);
  }
}

// The source pad runs the task (as `queue` does): activated before the sink
// pad, it starts it; deactivated first, it stops it (the task holds the
// pad's stream lock while it waits, so the flag and the signal come first).
static gboolean lf_request_queue_src_activate_mode(GstPad*, GstObject* parent, GstPadMode mode,
                                                   gboolean active) {
  LfRequestQueue* self = LF_REQUEST_QUEUE(parent);
  if (mode != GST_PAD_MODE_PUSH) return FALSE;
  if (active)
    lf_request_queue_start(self);
  else
    lf_request_queue_stop(self);
  return TRUE;
}

static void lf_request_queue_set_property(GObject* obj, guint id, const GValue* v, GParamSpec* ps) {
  props.set(obj, *LF_REQUEST_QUEUE(obj)->settings, id, v, ps);
}

static void lf_request_queue_get_property(GObject* obj, guint id, GValue* v, GParamSpec* ps) {
  props.get(obj, *LF_REQUEST_QUEUE(obj)->settings, id, v, ps);
}

static void lf_request_queue_finalize(GObject* obj) {
  LfRequestQueue* self = LF_REQUEST_QUEUE(obj);
  release(self->queue->clear());
  delete self->queue;
  g_mutex_clear(&self->lock);
  g_cond_clear(&self->cond);
  delete self->settings;
  G_OBJECT_CLASS(lf_request_queue_parent_class)->finalize(obj);
}

static void lf_request_queue_class_init(LfRequestQueueClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  oc->set_property = lf_request_queue_set_property;
  oc->get_property = lf_request_queue_get_property;
  oc->finalize = lf_request_queue_finalize;
  props.add(oc, &Settings::max_age,
            g_param_spec_uint64("max-age", "Max age",
                                "A viewer's request waiting behind one of the same viewer this "
                                "much newer (ns, by their PTS) is dropped as stale; 0: only each "
                                "viewer's newest request waits (the newest request wins). Read "
                                "when the element starts",
                                0, G_MAXUINT64, kDefaultMaxAge, lfgst::kReadWriteReady));
  props.add(oc, &Settings::dropped,
            lfgst::counter_spec("dropped", "Dropped",
                                "View requests dropped as stale (or over the 64 that may wait) "
                                "so far"));
  gst_element_class_add_static_pad_template(ec, &sink_template);
  gst_element_class_add_static_pad_template(ec, &src_template);
  gst_element_class_set_static_metadata(
      ec, "Light field view request queue", "Generic",
      "Queues view requests on a thread of its own, keeping each viewer's newest (load shed, "
      "not queued) and serving the viewers in turns weighted by their views' pixels",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess is-live=true "
      "num-buffers=30 focal-surface=false ! lfrequestqueue ! lfcamerahost "
      "rig=../shared/data/stanford-chess is-live=true ! lfcompositor "
      "rig=../shared/data/stanford-chess ! videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Caps go downstream with the requests they came before (each viewer's view size and "
      "rate), end of stream after the queued requests, other serialized events at once; "
      "dropped requests are counted in dropped.");
  GST_DEBUG_CATEGORY_INIT(lf_request_queue_debug, "lfrequestqueue", 0,
                          "light field view request queue");
}

static void lf_request_queue_init(LfRequestQueue* self) {
  self->settings = new Settings();
  self->settings->max_age = kDefaultMaxAge;
  g_mutex_init(&self->lock);
  g_cond_init(&self->cond);
  self->queue = new lf::RequestQueue<Queued>(kCapacity, kDefaultMaxAge);
  self->flushing = true;
  self->eos = false;
  self->last_ret = GST_FLOW_FLUSHING;
  self->sinkpad = gst_pad_new_from_static_template(&sink_template, "sink");
  gst_pad_set_chain_function(self->sinkpad, lf_request_queue_chain);
  gst_pad_set_event_function(self->sinkpad, lf_request_queue_sink_event);
  GST_PAD_SET_PROXY_CAPS(self->sinkpad);
  GST_PAD_SET_PROXY_ALLOCATION(self->sinkpad);
  gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);
  self->srcpad = gst_pad_new_from_static_template(&src_template, "src");
  gst_pad_set_activatemode_function(self->srcpad, lf_request_queue_src_activate_mode);
  GST_PAD_SET_PROXY_CAPS(self->srcpad);
  gst_element_add_pad(GST_ELEMENT(self), self->srcpad);
}
