// lfviewrequest: a viewer's view requests (Yang et al. 2002, Section 4.3).
// The element's documentation, properties and metadata (what
// gst-inspect-1.0 and docs/elements.md show) are in gst/lfviewprops.cpp;
// the viewer itself is lf::ViewerSession (lib/lf/session/viewer_session.h).
// This file is the glue: base-source vfuncs, upstream events, clock, buffers.
#include <gst/base/gstbasesrc.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <vector>

#include "lf/io/parse.h"
#include "lf/session/viewer_session.h"
#include "lf/wire/probe_bundle.h"
#include "lfcaps.h"
#include "lfclock.h"
#include "lfevents.h"
#include "lfguard.h"
#include "lfprops.h"
#include "lfrig.h"
#include "lftrace.h"
#include "lfviewprops.h"
#include "lfwarn.h"

GST_DEBUG_CATEGORY_STATIC(lf_view_request_debug);
#define GST_CAT_DEFAULT lf_view_request_debug

G_BEGIN_DECLS
#define LF_TYPE_VIEW_REQUEST (lf_view_request_get_type())
G_DECLARE_FINAL_TYPE(LfViewRequest, lf_view_request, LF, VIEW_REQUEST, GstBaseSrc)
G_END_DECLS

namespace {
using Settings = lfgst::ViewRequestSettings;
constexpr double kMaxCoord = lfgst::kMaxCoordinate;

// From READY->PAUSED to PAUSED->READY.
struct State {
  // Fixed from start: rig, viewer-id, size, rate, live (caps and schedule).
  Settings fixed;
  // The viewer (Priv::lock): its views, replaced when the view settings
  // change (streaming thread), navigation, focus and surface schedules.
  std::unique_ptr<lf::ViewerSession> session;
  guint applied = 0;  // settings generation the views were built from
  guint64 sequence = 0;
  guint32 last_seqnum = GST_SEQNUM_INVALID;  // of the last event applied (Priv::lock)
  lfgst::TickBacklog rest_of_tick;           // the right eye, probes (streaming thread)
};
// A non-live source waits this long at most for a surface probe's answer.
constexpr GstClockTime kSurfaceWaitNonLive = 2 * GST_SECOND;

struct Priv {
  Settings settings;  // properties (object lock)
  // Bumped whenever a view property changes (any thread).
  std::atomic<guint> generation{0};
  // Held while an lf-view event sets several properties and while the
  // streaming thread snapshots them, so a request sees all or none.
  GMutex apply_lock;
  GMutex lock;  // guards `state` against the event threads
  std::unique_ptr<State> state;
  // The clock (live) and a surface answer (not live) are waited for here;
  // notified when an answer comes.
  lfgst::ClockWaiter waiter;
  lfgst::WarnLimiter bad_view, bad_event;
  Priv() { g_mutex_init(&lock), g_mutex_init(&apply_lock); }
  ~Priv() { g_mutex_clear(&lock), g_mutex_clear(&apply_lock); }
};

lfgst::Properties<Settings> props;
lfgst::ViewRequestSpecs specs;
}  // namespace

struct _LfViewRequest {
  GstBaseSrc parent;
  Priv* priv;
};

G_DEFINE_TYPE(LfViewRequest, lf_view_request, GST_TYPE_BASE_SRC)
GST_ELEMENT_REGISTER_DEFINE(lfviewrequest, "lfviewrequest", GST_RANK_NONE, LF_TYPE_VIEW_REQUEST)

static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_REQUEST_CAPS));

static void lf_view_request_property_set(GObject* obj, GParamSpec* ps, const GValue* v) {
  lfgst::apply_is_live(obj, ps, v);
  if (ps->flags & GST_PARAM_MUTABLE_PLAYING) LF_VIEW_REQUEST(obj)->priv->generation++;
}
LF_DEFINE_ELEMENT_GLUE(lf_view_request, LF_VIEW_REQUEST)

// The rig and views of settings `s`, or null after an element error.
static std::shared_ptr<const lf::ViewerViews> checked_views(LfViewRequest* self, const Settings& s,
                                                            std::shared_ptr<const lf::Rig>* rig) {
  *rig = lfgst::open_rig(GST_ELEMENT(self), s.rig);  // posts its own error
  if (!*rig) return nullptr;
  std::shared_ptr<const lf::ViewerViews> views;
  GError* err = nullptr;
  if (!lfgst::guard([&] { views = lf::build_viewer_views(s, **rig); }, &err)) {
    GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Invalid view request settings"),
                      ("%s", err->message));
    g_error_free(err);
  }
  return views;
}

static gboolean lf_view_request_start(GstBaseSrc* src) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  Priv* p = self->priv;
  auto st = std::make_unique<State>();
  st->applied = p->generation.load();
  st->fixed = lfgst::snapshot(GST_OBJECT(self), p->settings);
  const Settings& s = st->fixed;
  if (s.framerate.n <= 0 || s.framerate.d <= 0) {
    GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Invalid framerate"),
                      ("framerate must be positive, got %d/%d", s.framerate.n, s.framerate.d));
    return FALSE;
  }
  std::shared_ptr<const lf::Rig> rig;
  std::shared_ptr<const lf::ViewerViews> views = checked_views(self, s, &rig);
  if (!views) return FALSE;
  // A plane behind the cameras is legal but gives empty (black) views: say so.
  if (const double depth = lf::focal_plane_depth(*rig, views->plane); depth <= 0)
    GST_ELEMENT_WARNING(self, LIBRARY, SETTINGS, ("Focal plane behind the cameras"),
                        ("focal-plane '%s' lies %g rig units behind the camera plane: every view "
                         "focused there is empty (black); a plane in front has a positive depth "
                         "(depth:Z with Z > 0)",
                         s.focal_plane.c_str(), -depth));
  st->session = std::make_unique<lf::ViewerSession>(rig, s.viewer_id, std::move(views));
  g_mutex_lock(&p->lock);
  p->state = std::move(st);
  g_mutex_unlock(&p->lock);
  return TRUE;
}

// NULL -> READY: the rig and the view settings are checked here, so that a
// bad value gives one error (its own) and the state change fails; at start
// (READY -> PAUSED) GstBaseSrc adds a second, generic "Failed to start"
// error after the element's.
static GstStateChangeReturn lf_view_request_change_state(GstElement* el, GstStateChange t) {
  if (t == GST_STATE_CHANGE_NULL_TO_READY) {
    LfViewRequest* self = LF_VIEW_REQUEST(el);
    const Settings s = lfgst::snapshot(GST_OBJECT(self), self->priv->settings);
    std::shared_ptr<const lf::Rig> rig;
    // (No rig yet: it may still be set in READY; start() checks it then.)
    if (!s.rig.empty() && !checked_views(self, s, &rig)) return GST_STATE_CHANGE_FAILURE;
  }
  return GST_ELEMENT_CLASS(lf_view_request_parent_class)->change_state(el, t);
}

static gboolean lf_view_request_stop(GstBaseSrc* src) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  g_mutex_lock(&self->priv->lock);
  self->priv->state.reset();
  g_mutex_unlock(&self->priv->lock);
  return TRUE;
}

static GstCaps* lf_view_request_get_caps(GstBaseSrc* src, GstCaps* filter) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  const Settings s = lfgst::snapshot(GST_OBJECT(self), self->priv->settings);
  GstCaps* caps = gst_caps_new_simple("application/x-lf-view-request", "framerate",
                                      GST_TYPE_FRACTION, s.framerate.n, s.framerate.d, "width",
                                      G_TYPE_INT, s.width, "height", G_TYPE_INT, s.height, nullptr);
  if (filter) {
    GstCaps* t = gst_caps_intersect_full(filter, caps, GST_CAPS_INTERSECT_FIRST);
    gst_caps_unref(caps);
    caps = t;
  }
  return caps;
}

LF_DEFINE_SRC_UNLOCK(lf_view_request, LF_VIEW_REQUEST)

// The event is for this viewer: it names no viewer, or this one (or, with a
// stereo baseline, the right eye's).
static bool for_this_viewer(LfViewRequest* self, const GstStructure* st) {
  const std::optional<guint> id = lfgst::addressed_viewer(st);
  GstObject* o = GST_OBJECT(self);
  const Settings& s = self->priv->settings;
  const guint v = id ? lfgst::read_setting(o, s, &Settings::viewer_id) : 0;
  return !id || *id == v ||
         (*id == v + 1 && lfgst::read_setting(o, s, &Settings::stereo_baseline) > 0);
}

// Sets eye-s/t/w and focal-depth from a navigation gesture, then notifies.
static void set_navigated(LfViewRequest* self, const lf::EyeAndFocus& v) {
  Priv* p = self->priv;
  GST_OBJECT_LOCK(self);
  p->settings.eye_s = v.eye[0], p->settings.eye_t = v.eye[1], p->settings.eye_w = v.eye[2];
  p->settings.focal_depth = v.focal_depth;
  GST_OBJECT_UNLOCK(self);
  p->generation++;
  g_object_freeze_notify(G_OBJECT(self));
  for (GParamSpec* ps : {specs.eye_s, specs.eye_t, specs.eye_w, specs.focal_depth})
    g_object_notify_by_pspec(G_OBJECT(self), ps);
  g_object_thaw_notify(G_OBJECT(self));
}

static void handle_navigation(LfViewRequest* self, GstEvent* event) {
  Priv* p = self->priv;
  lf::Gesture g;
  if (!lfgst::read_gesture(event, &g)) return;
  g_mutex_lock(&p->lock);
  State* st = p->state.get();
  // Every camera branch forwards the same event upstream: apply it once.
  const guint32 seq = gst_event_get_seqnum(event);
  std::optional<lf::EyeAndFocus> v;
  if (st && seq != st->last_seqnum) {
    st->last_seqnum = seq;
    v = st->session->navigate(g, lfgst::snapshot(GST_OBJECT(self), p->settings), kMaxCoord);
  }
  g_mutex_unlock(&p->lock);
  if (v) {
    GST_DEBUG_OBJECT(self, "navigation: eye (s, t, w) = (%g, %g, %g), focal depth %g", v->eye[0],
                     v->eye[1], v->eye[2], v->focal_depth);
    set_navigated(self, *v);
  }
}

// An lf-view event: checks every field, then sets them all at once.
static void handle_view_event(LfViewRequest* self, GstEvent* event) {
  Priv* p = self->priv;
  const GstStructure* st = gst_event_get_structure(event);
  g_mutex_lock(&p->lock);
  State* state = p->state.get();
  const guint32 seq = gst_event_get_seqnum(event);
  const bool fresh = !state || seq != state->last_seqnum;
  if (state) state->last_seqnum = seq;
  g_mutex_unlock(&p->lock);
  if (!fresh) return;
  std::vector<std::pair<GParamSpec*, GValue>> values;
  std::string why;
  lfgst::read_view_change(st, G_OBJECT(self), kMaxCoord, &values, &why);
  if (why.empty()) {
    g_mutex_lock(&p->apply_lock);  // the streaming thread sees all or none
    for (auto& [ps, v] : values) g_object_set_property(G_OBJECT(self), ps->name, &v);
    g_mutex_unlock(&p->apply_lock);
    GST_DEBUG_OBJECT(self, "lf-view event: %u fields applied", static_cast<guint>(values.size()));
  } else {
    LF_ELEMENT_WARNING_LIMITED(self, p->bad_event, STREAM, FAILED,
                               ("Ignoring an lf-view event with a bad field"), "%s", why.c_str());
  }
  for (auto& kv : values) g_value_unset(&kv.second);
}

// An lf-focus event (lfcompositor's answer to a focus probe): the focal
// plane goes to the inverse depth found, once per probe.
static void handle_focus_event(LfViewRequest* self, GstEvent* event) {
  Priv* p = self->priv;
  lfgst::FocusAnswer a;
  std::string why;
  if (!lfgst::read_focus(gst_event_get_structure(event), &a, &why)) {
    LF_ELEMENT_WARNING_LIMITED(self, p->bad_event, STREAM, FAILED,
                               ("Ignoring a malformed lf-focus event"), "%s", why.c_str());
    return;
  }
  g_mutex_lock(&p->lock);
  State* st = p->state.get();
  const Settings s = lfgst::snapshot(GST_OBJECT(self), p->settings);
  // Applied once, the last click's as it is, continuous ones part of the
  // way from the plane in use (lf::FocusSchedule::answer).
  const double depth =
      st ? st->session->focus_answer(a.probe, a.inverse_depth, s.focal_depth, kMaxCoord).value_or(0)
         : 0;
  g_mutex_unlock(&p->lock);
  if (!(depth > 0)) return;
  GST_DEBUG_OBJECT(self, "focused by probe %u: depth %g", a.probe, depth);
  set_navigated(self, {{s.eye_s, s.eye_t, s.eye_w}, depth});
}

// An lf-surface event (lfcompositor's answer to a surface probe): the
// surface that the next requests carry, once per probe and never one older
// than the surface in use. Sizes are checked here, the surface against the
// view when a request takes it (lf::validate).
static void handle_surface_event(LfViewRequest* self, GstEvent* event) {
  Priv* p = self->priv;
  lfgst::SurfaceAnswer a;
  std::string why;
  if (!lfgst::read_surface(gst_event_get_structure(event), &a, &why)) {
    LF_ELEMENT_WARNING_LIMITED(self, p->bad_event, STREAM, FAILED,
                               ("Ignoring a malformed lf-surface event"), "%s (gst/lfevents.h)",
                               why.c_str());
    return;
  }
  const guint probe = a.probe;
  g_mutex_lock(&p->lock);
  State* st = p->state.get();
  const bool fresh = st && st->session->surface().answer(probe, std::move(a.surface));
  g_mutex_unlock(&p->lock);
  p->waiter.notify();
  GST_DEBUG_OBJECT(self, "surface probe %u answered%s", probe, fresh ? "" : " (not ours or stale)");
}

static gboolean lf_view_request_event(GstBaseSrc* src, GstEvent* event) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  const GstStructure* st = gst_event_get_structure(event);
  void (*handler)(LfViewRequest*, GstEvent*) = nullptr;
  if (GST_EVENT_TYPE(event) == GST_EVENT_NAVIGATION)
    handler = handle_navigation;
  else if (GST_EVENT_TYPE(event) == GST_EVENT_CUSTOM_UPSTREAM &&
           gst_event_has_name(event, "lf-surface"))
    handler = handle_surface_event;
  else if (GST_EVENT_TYPE(event) == GST_EVENT_CUSTOM_UPSTREAM &&
           gst_event_has_name(event, "lf-focus"))
    handler = handle_focus_event;
  else if (GST_EVENT_TYPE(event) == GST_EVENT_CUSTOM_UPSTREAM &&
           gst_event_has_name(event, "lf-view"))
    handler = handle_view_event;
  if (handler) {
    if (for_this_viewer(self, st)) handler(self, event);
    return TRUE;
  }
  if (lfgst::refuse_seek(GST_ELEMENT(src), event)) return FALSE;
  return GST_BASE_SRC_CLASS(lf_view_request_parent_class)->event(src, event);
}

// A buffer of one request, or of a probe's steps as a bundle
// (lib/lf/wire/probe_bundle.h), for time `pts`; nullptr (with a warning) if they
// cannot be serialized.
static GstBuffer* request_buffer(GstBaseSrc* src, std::vector<lf::ViewRequest> timed,
                                 GstClockTime pts, GstClockTime period) {
  for (lf::ViewRequest& r : timed) {
    lfgst::trace(GST_ELEMENT(src), "issue", r.viewer_id, r.sequence, -1, static_cast<gint64>(pts));
    // The request is for its PTS (cameras: frame-select).
    r.time_ns = GST_CLOCK_TIME_IS_VALID(pts) ? static_cast<int64_t>(pts) : -1;
  }
  std::vector<uint8_t> bytes;
  GError* err = nullptr;
  if (!lfgst::guard([&] { bytes = lf::serialize_requests(timed); }, &err)) {
    GST_WARNING_OBJECT(src, "cannot serialize a view request: %s", err->message);
    g_error_free(err);
    return nullptr;
  }
  GstBuffer* buf = gst_buffer_new_memdup(bytes.data(), bytes.size());
  GST_BUFFER_PTS(buf) = pts;
  GST_BUFFER_DTS(buf) = pts;
  GST_BUFFER_DURATION(buf) = period;
  GST_BUFFER_OFFSET(buf) = timed[0].sequence;
  return buf;
}

// Controller values synced for request time `pts`, and the views rebuilt
// when a view property changed since the last request (a bad change is
// warned about and the previous views stay).
static void sync_views(LfViewRequest* self, State* st, GstClockTime pts) {
  Priv* p = self->priv;
  gst_object_sync_values(GST_OBJECT(self), pts);
  const guint gen = p->generation.load();
  if (gen == st->applied) return;
  g_mutex_lock(&p->apply_lock);
  Settings s = lfgst::snapshot(GST_OBJECT(self), p->settings);
  g_mutex_unlock(&p->apply_lock);
  // Caps and schedule stay as started.
  s.width = st->fixed.width, s.height = st->fixed.height;
  std::shared_ptr<const lf::ViewerViews> v;
  GError* err = nullptr;
  if (lfgst::guard([&] { v = lf::build_viewer_views(s, st->session->rig()); }, &err)) {
    g_mutex_lock(&p->lock);
    st->session->set_views(std::move(v));
    g_mutex_unlock(&p->lock);
  } else {
    LF_ELEMENT_WARNING_LIMITED(self, p->bad_view, LIBRARY, SETTINGS,
                               ("Ignoring invalid view settings; the previous view stays"), "%s",
                               err->message);
    g_error_free(err);
  }
  st->applied = gen;
}

// Non-live: the first request after a surface probe waits for its answer
// (at most kSurfaceWaitNonLive, once per probe), or a source that runs
// ahead of the pipeline would make every request of a short run before the
// answer came. Live sources never wait: the answer applies when it comes.
// False when unlocked (flushing); *first_failed when no probe was ever
// answered.
static bool wait_for_surface(LfViewRequest* self, State* st, bool* first_failed) {
  Priv* p = self->priv;
  lf::SurfaceSchedule& surface = st->session->surface();
  const auto locked = [p](auto f) {
    g_mutex_lock(&p->lock);
    const auto r = f();
    g_mutex_unlock(&p->lock);
    return r;
  };
  const std::optional<uint32_t> id = locked([&] { return surface.wait_for(); });
  if (!id) return true;
  if (!p->waiter.wait_for([&] { return !locked([&] { return surface.awaiting(); }); },
                          kSurfaceWaitNonLive / GST_USECOND))
    return false;
  *first_failed = !locked([&] { return surface.ever_answered(); });
  GST_DEBUG_OBJECT(self, "surface probe %u: %s", *id, *first_failed ? "no answer" : "answered");
  return true;
}

// A tick's notices as warnings (or debug lines).
static void report(LfViewRequest* self, const lf::ViewerTick& t) {
  Priv* p = self->priv;
  for (const lf::ViewerNotice& n : t.notices) {
    if (const char* what = n.summary())
      LF_ELEMENT_WARNING_LIMITED(self, p->bad_view, LIBRARY, SETTINGS, ("%s", what), "%s",
                                 n.detail.c_str());
    else
      GST_WARNING_OBJECT(self, "no probe: %s", n.detail.c_str());
  }
  if (t.focus_probe)
    GST_DEBUG_OBJECT(self, "%s focus probe %u at (%g, %g)",
                     t.focus_probe->click ? "click" : "continuous", t.focus_probe->id,
                     t.focus_probe->x, t.focus_probe->y);
  if (t.surface_probe) GST_DEBUG_OBJECT(self, "surface probe %u", t.surface_probe);
  if (t.gave_up)
    GST_ELEMENT_WARNING(
        self, STREAM, FAILED, ("No answer to the focal surface probes: using focal-plane"),
        ("%u surface probes sent, none answered: no lfcompositor downstream in this pipeline "
         "answers them (across hosts, the compositor's answers cannot reach this element), or "
         "it could not estimate a surface (its warning says why); set focal-surface=false to "
         "focus on focal-plane without probing",
         t.surface_probes_sent));
  if (t.refocused) {
    GST_INFO_OBJECT(self, "refocused on a plane: focal-surface off");
    g_object_set(self, "focal-surface", FALSE, nullptr);
  }
  GST_OBJECT_LOCK(self);
  p->settings.surface_planes = t.surface_planes;
  p->settings.surface_two_plane_tiles = t.two_plane_tiles;
  GST_OBJECT_UNLOCK(self);
}

static GstFlowReturn lf_view_request_create(GstBaseSrc* src, guint64, guint, GstBuffer** out) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  Priv* p = self->priv;
  State* st = p->state.get();
  if ((*out = st->rest_of_tick.pop())) return GST_FLOW_OK;
  const Settings& fixed = st->fixed;
  bool first_wait_failed = false;
  if (!fixed.live && !wait_for_surface(self, st, &first_wait_failed)) return GST_FLOW_FLUSHING;
  const GstClockTime period =
      gst_util_uint64_scale_int(GST_SECOND, fixed.framerate.d, fixed.framerate.n);
  if (fixed.live)  // a viewer joining late starts at the current tick
    st->sequence = lfgst::first_current_tick(GST_ELEMENT(src), st->sequence, period, 0);
  const guint64 k = st->sequence;
  const GstClockTime pts = k * period;
  // Live: emit at running time pts on the pipeline clock.
  if (fixed.live && !p->waiter.wait_until(GST_ELEMENT(src), pts)) return GST_FLOW_FLUSHING;
  sync_views(self, st, pts);
  const Settings now = lfgst::snapshot(GST_OBJECT(self), p->settings);
  g_mutex_lock(&p->lock);
  const lf::ViewerTick tick = st->session->tick(k, now, static_cast<int64_t>(period / GST_USECOND),
                                                g_get_monotonic_time(), first_wait_failed);
  g_mutex_unlock(&p->lock);
  report(self, tick);
  // The tick's first request now, the others from the next calls, at once
  // (num-buffers counts ticks: the base class counts each call).
  std::vector<GstBuffer*> bufs;
  for (const lf::ViewRequest& r : tick.requests)
    bufs.push_back(request_buffer(src, {r}, pts, period));
  for (const std::vector<lf::ViewRequest>& probe : tick.probes)
    bufs.push_back(request_buffer(src, probe, pts, period));
  bufs.erase(std::remove(bufs.begin(), bufs.end(), nullptr), bufs.end());
  if (bufs.empty()) {
    GST_ELEMENT_ERROR(self, LIBRARY, FAILED, ("Cannot serialize the view request"),
                      ("request %" G_GUINT64_FORMAT, k));
    return GST_FLOW_ERROR;
  }
  *out = st->rest_of_tick.push(src, bufs);
  st->sequence++;
  return GST_FLOW_OK;
}

static gboolean lf_view_request_query(GstBaseSrc* src, GstQuery* q) {
  if (lfgst::answer_live_latency(src, q)) return TRUE;
  return GST_BASE_SRC_CLASS(lf_view_request_parent_class)->query(src, q);
}

static void lf_view_request_init(LfViewRequest* self) {
  self->priv = new Priv();
  gst_base_src_set_format(GST_BASE_SRC(self), GST_FORMAT_TIME);
}

static void lf_view_request_class_init(LfViewRequestClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  ec->change_state = lf_view_request_change_state;
  GstBaseSrcClass* bc = GST_BASE_SRC_CLASS(klass);
  oc->set_property = lf_view_request_set_property;
  oc->get_property = lf_view_request_get_property;
  oc->finalize = lf_view_request_finalize;
  specs = lfgst::install_view_request_properties(oc, &props);
  lfgst::install_view_request_actions(oc);
  gst_element_class_add_static_pad_template(ec, &src_template);
  lfgst::describe_view_request(ec);
  bc->start = lf_view_request_start;
  bc->stop = lf_view_request_stop;
  bc->get_caps = lf_view_request_get_caps;
  bc->create = lf_view_request_create;
  bc->unlock = lf_view_request_unlock;
  bc->unlock_stop = lf_view_request_unlock_stop;
  bc->query = lf_view_request_query;
  bc->event = lf_view_request_event;
  GST_DEBUG_CATEGORY_INIT(lf_view_request_debug, "lfviewrequest", 0, "light field view requests");
}
