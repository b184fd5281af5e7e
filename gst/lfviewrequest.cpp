/**
 * SECTION:element-lfviewrequest
 * @title: lfviewrequest
 *
 * Produces view requests (Yang et al. 2002, Section 4.3: a virtual view and a
 * focal plane) at a rate, for one viewer: a fixed view from the properties, a
 * keyframed camera path (`path`) or an orbit over the camera plane (`orbit`).
 * Output: `application/x-lf-view-request` buffers (byte layout in
 * lib/lf/wire/wire.h) whose caps carry the request `framerate`, `width` and
 * `height`. Positions are in the rig's units and world frame
 * (lib/lf/geometry/rig.h); views are built by lib/lf/geometry/view_builder.h,
 * as `lf-render` builds them. The viewer's state from request to request
 * (click-to-focus probes, the focal surface's probe cadence, navigation
 * gestures) is lib/lf/session/viewer.h; this element is its glue.
 *
 * Steering while playing (docs/steering.md): the view properties are
 * changeable in PLAYING and apply from the next request on; some are
 * controllable (interpolated camera moves). An upstream `lf-view` event
 * (gst/lfevents.h) sets several at once, checked whole; navigation events
 * from the video sink drag the eye, move the focal plane with the wheel, and
 * focus where the user right-clicks (a focus probe, answered by
 * `lfcompositor` with an `lf-focus` event).
 *
 * Focal surface (the default; docs/rendering.md): every `surface-interval`
 * requests a surface probe goes out with the tick's request and
 * `lfcompositor` answers with an `lf-surface` event, a plane per 16-pixel
 * tile that the next requests carry (view request version 3). The paper's
 * single focal plane is `focal-surface=false`; refocusing while playing sets
 * it so (notified). Without any answer (no compositor in this pipeline) the
 * probes stop with one warning and `focal-plane` holds.
 *
 * `aperture` / `f-number` widen the paper's tent aperture, `ulr-cameras`
 * uses Unstructured Lumigraph weights, `sampling=bicubic` Keys' cubic in
 * place of bilinear (lib/lf/geometry/view.h; figures in docs/rendering.md).
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=rig.json position="<0,0,0>" focal-plane=depth:2 \
 *   num-buffers=1 ! fakesink dump=true
 * ]|
 */
#include <gst/base/gstbasesrc.h>
#include <gst/video/navigation.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "lf/focus/focus.h"
#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/parse.h"
#include "lf/session/viewer.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"
#include "lfcaps.h"
#include "lfclock.h"
#include "lfevents.h"
#include "lfguard.h"
#include "lfprops.h"
#include "lfrig.h"
#include "lftrace.h"
#include "lfwarn.h"

GST_DEBUG_CATEGORY_STATIC(lf_view_request_debug);
#define GST_CAT_DEFAULT lf_view_request_debug

G_BEGIN_DECLS
#define LF_TYPE_VIEW_REQUEST (lf_view_request_get_type())
G_DECLARE_FINAL_TYPE(LfViewRequest, lf_view_request, LF, VIEW_REQUEST, GstBaseSrc)
G_END_DECLS

#define DEFAULT_VIEWER_ID 0
#define DEFAULT_WIDTH 640
#define DEFAULT_HEIGHT 480
#define DEFAULT_VFOV 0.0
#define DEFAULT_FOCAL_PLANE "infinity"
#define DEFAULT_FOCAL_DEPTH 0.0
#define DEFAULT_ORBIT 0.0
#define DEFAULT_DOLLY 0.0
#define DEFAULT_PATH_FRAMES 120
#define DEFAULT_FPS_N 30
#define DEFAULT_FPS_D 1
#define DEFAULT_IS_LIVE FALSE
#define DEFAULT_STEREO_BASELINE 0.0
#define DEFAULT_SURFACE_INTERVAL 60
// Largest eye offset or coordinate, rig units.
#define MAX_COORD 1e12

namespace {
struct Settings {
  std::string rig;
  guint viewer_id = DEFAULT_VIEWER_ID;
  gint width = DEFAULT_WIDTH, height = DEFAULT_HEIGHT;
  std::vector<double> position, look_at;  // 3 numbers, or empty (unset)
  gdouble eye_s = 0, eye_t = 0, eye_w = 0;
  gdouble vfov = DEFAULT_VFOV;
  std::string focal_plane = DEFAULT_FOCAL_PLANE;
  gdouble focal_depth = DEFAULT_FOCAL_DEPTH;
  gdouble aperture = 0, f_number = 0;  // rig units; full-frame-equivalent
  guint ulr_cameras = 0;               // 0: the tent (aperture, f-number); else ULR's k
  lf::Sampling sampling = lf::Sampling::kBilinear;
  std::string path;
  gdouble orbit = DEFAULT_ORBIT, dolly = DEFAULT_DOLLY;
  gint path_frames = DEFAULT_PATH_FRAMES;
  lfgst::Fraction framerate{DEFAULT_FPS_N, DEFAULT_FPS_D};
  bool live = DEFAULT_IS_LIVE;
  gdouble stereo_baseline = DEFAULT_STEREO_BASELINE;
  bool continuous_focus = false;
  bool focal_surface = true;
  guint surface_interval = DEFAULT_SURFACE_INTERVAL;
  guint surface_planes = 0;           // read-only: planes of the surface in use (object lock)
  guint surface_two_plane_tiles = 0;  // read-only: its tiles with a second plane
  // A quilt (lib/lf/render/quilt.h): 0 views for one view; width x height is then
  // the quilt frame, of quilt_cols x quilt_rows tiles.
  guint quilt_views = 0, quilt_cols = 8, quilt_rows = 6;
  gdouble view_cone = 0, quilt_baseline = 0;  // degrees; rig units (0 and 0: the array's width)
};

// The views and focal plane that the view settings describe.
struct Views {
  Settings s;  // the settings they were built from
  lf::ViewSequence sequence;
  lf::FocalPlane plane;
};

// From READY->PAUSED to PAUSED->READY.
struct State {
  std::shared_ptr<const lf::Rig> rig;
  // Fixed from start: rig, viewer-id, size, rate, live (caps and schedule).
  Settings fixed;
  // Built from the view settings; replaced when they change (streaming
  // thread), read by the navigation handler (both under Priv::lock).
  std::shared_ptr<const Views> views;
  guint applied = 0;  // settings generation the views were built from
  guint64 sequence = 0;
  // Navigation gestures (Priv::lock).
  bool dragging = false;
  double drag_x = 0, drag_y = 0;
  guint32 last_seqnum = GST_SEQNUM_INVALID;
  // Click to focus and continuous focus (Priv::lock;
  // lib/lf/session/viewer.h).
  lf::FocusSchedule focus;
  // The rest of the current tick's requests (the right eye, focus probes),
  // given out by the next create() calls (streaming thread). Not a buffer
  // list: GstBaseSrc 1.22 unrefs a NULL buffer when a state change meets a
  // submitted list (gst_base_src_get_range), a CRITICAL on a busy machine.
  std::deque<GstBuffer*> rest_of_tick;
  // The focal surface's probes and the surface in use (Priv::lock;
  // lib/lf/session/viewer.h).
  lf::SurfaceSchedule surface;
  ~State() {
    for (GstBuffer* b : rest_of_tick) gst_buffer_unref(b);
  }
};
// A click whose probe has no answer this long after it (at least this many
// requests) is probed again (lf::FocusSchedule).
constexpr GstClockTime kClickRetryAfter = GST_SECOND;
constexpr guint64 kClickRetryTicks = 5;
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
  // Signalled (under `lock`) when a surface answer comes or the element is
  // unlocked (flushing): a non-live source waits on it for a probe's answer.
  GCond surface_cond;
  bool unlocked = false;  // between unlock and unlock_stop (under `lock`)
  std::unique_ptr<State> state;
  lfgst::ClockWaiter waiter;
  lfgst::WarnLimiter bad_view, bad_event;
  Priv() { g_mutex_init(&lock), g_mutex_init(&apply_lock), g_cond_init(&surface_cond); }
  ~Priv() { g_mutex_clear(&lock), g_mutex_clear(&apply_lock), g_cond_clear(&surface_cond); }
};

lfgst::Properties<Settings> props;
GParamSpec* spec_eye_s = nullptr;
GParamSpec* spec_eye_t = nullptr;
GParamSpec* spec_eye_w = nullptr;
GParamSpec* spec_focal_depth = nullptr;
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

static std::optional<cv::Vec3d> point(const std::vector<double>& p, const char* what) {
  if (p.empty()) return std::nullopt;
  if (p.size() != 3 || !std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
    throw std::invalid_argument(std::string(what) + " needs 3 finite numbers, <x, y, z>");
  return cv::Vec3d(p[0], p[1], p[2]);
}

// The quilt layout of the settings (its baseline is set per request).
static lf::Quilt quilt_of(const Settings& s) {
  lf::Quilt q;
  q.views = static_cast<int>(s.quilt_views);
  q.cols = static_cast<int>(s.quilt_cols), q.rows = static_cast<int>(s.quilt_rows);
  return q;
}

// Builds the views of settings `s` (throws std::exception when they are bad).
static std::shared_ptr<const Views> build(const Settings& s, const lf::Rig& rig) {
  auto v = std::make_shared<Views>();
  v->s = s;
  lf::ViewSettings vs;
  vs.width = s.width;
  vs.height = s.height;
  if (s.quilt_views > 0) {  // each eye has the tile's size
    lf::validate_quilt(quilt_of(s), s.width, s.height);
    if (s.stereo_baseline > 0)
      throw std::invalid_argument("a quilt (quilt-views) and stereo-baseline cannot be combined");
    vs.width = s.width / static_cast<int>(s.quilt_cols);
    vs.height = s.height / static_cast<int>(s.quilt_rows);
  }
  vs.position = point(s.position, "position");
  vs.look_at = point(s.look_at, "look-at");
  vs.vfov_deg = s.vfov;
  vs.path_file = s.path;
  vs.orbit = s.orbit;
  vs.dolly = s.dolly;
  vs.path_frames = s.path_frames;
  v->sequence = lf::build_views(rig, vs);
  v->plane = s.focal_depth > 0 ? lf::plane_at_inverse_depth(rig, 1.0 / s.focal_depth)
                               : lf::parse_focal_plane(s.focal_plane, rig);
  return v;
}

#define LF_TYPE_SAMPLING (lf_sampling_get_type())
static GType lf_sampling_get_type() {
  static GType type = 0;
  static const GEnumValue values[] = {
      {static_cast<gint>(lf::Sampling::kBilinear), "Bilinear (the paper's)", "bilinear"},
      {static_cast<gint>(lf::Sampling::kBicubic),
       "Bicubic (Keys, a = -0.5): sharper, slower to warp", "bicubic"},
      {0, nullptr, nullptr}};
  return lfgst::enum_type(&type, "LfSampling", values);
}

// The aperture's scale (lf/geometry/view.h Aperture) for settings `s`: f-number
// (when > 0 and the rig's unit is a length) else aperture, in rig units;
// never below the tent.
static double aperture_scale(LfViewRequest* self, const lf::Rig& rig, const Settings& s,
                             const lf::VirtualView& view) {
  double diameter = s.aperture;
  if (s.f_number > 0) {
    const double mm = lf::millimetres_per_unit(rig.unit);
    if (mm > 0)
      diameter = lf::diameter_for_f_number(s.f_number, view.focal_px(), view.width, mm);
    else
      LF_ELEMENT_WARNING_LIMITED(
          self, self->priv->bad_view, LIBRARY, SETTINGS, ("Ignoring f-number"),
          "the rig's unit '%s' is not a length (mm, cm or m): set aperture in rig units",
          rig.unit.c_str());
  }
  return lf::aperture_scale_for(diameter, rig.typical_spacing());
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
  st->rig = lfgst::open_rig(GST_ELEMENT(self), s.rig);
  if (!st->rig) return FALSE;
  GError* err = nullptr;
  if (!lfgst::guard([&] { st->views = build(s, *st->rig); }, &err)) {
    GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Invalid view request settings"),
                      ("%s", err->message));
    g_error_free(err);
    return FALSE;
  }
  // A plane behind the cameras is legal but gives empty (black) views: say so.
  if (const double depth = lf::focal_plane_depth(*st->rig, st->views->plane); depth <= 0)
    GST_ELEMENT_WARNING(self, LIBRARY, SETTINGS, ("Focal plane behind the cameras"),
                        ("focal-plane '%s' lies %g rig units behind the camera plane: every view "
                         "focused there is empty (black); a plane in front has a positive depth "
                         "(depth:Z with Z > 0)",
                         s.focal_plane.c_str(), -depth));
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
    // (No rig yet: it may still be set in READY; start() checks it then.)
    if (s.rig.empty()) return GST_ELEMENT_CLASS(lf_view_request_parent_class)->change_state(el, t);
    auto rig = lfgst::open_rig(el, s.rig);  // posts its own error
    if (!rig) return GST_STATE_CHANGE_FAILURE;
    GError* err = nullptr;
    if (!lfgst::guard([&] { build(s, *rig); }, &err)) {
      GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Invalid view request settings"),
                        ("%s", err->message));
      g_error_free(err);
      return GST_STATE_CHANGE_FAILURE;
    }
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

static gboolean lf_view_request_unlock(GstBaseSrc* src) {
  Priv* p = LF_VIEW_REQUEST(src)->priv;
  p->waiter.unlock();
  g_mutex_lock(&p->lock);
  p->unlocked = true;
  g_cond_broadcast(&p->surface_cond);
  g_mutex_unlock(&p->lock);
  return TRUE;
}

static gboolean lf_view_request_unlock_stop(GstBaseSrc* src) {
  Priv* p = LF_VIEW_REQUEST(src)->priv;
  p->waiter.unlock_stop();
  g_mutex_lock(&p->lock);
  p->unlocked = false;
  g_mutex_unlock(&p->lock);
  return TRUE;
}

// The event is for this viewer: it names no viewer, or this one (or, with a
// stereo baseline, the right eye's).
static bool for_this_viewer(LfViewRequest* self, const GstStructure* st) {
  guint id = 0;
  gint sid = 0;
  bool named = gst_structure_get_uint(st, "viewer-id", &id);
  if (!named && gst_structure_get_int(st, "viewer-id", &sid) && sid >= 0)
    named = true, id = static_cast<guint>(sid);
  if (!named) return true;
  GstObject* obj = GST_OBJECT(self);
  const guint viewer = lfgst::read_setting(obj, self->priv->settings, &Settings::viewer_id);
  const double baseline =
      lfgst::read_setting(obj, self->priv->settings, &Settings::stereo_baseline);
  return id == viewer || (baseline > 0 && id == viewer + 1);
}

// Sets eye-s/t/w and focal-depth from a navigation gesture, then notifies.
static void set_navigated(LfViewRequest* self, const cv::Vec3d& eye, double focal_depth) {
  Priv* p = self->priv;
  GST_OBJECT_LOCK(self);
  p->settings.eye_s = eye[0], p->settings.eye_t = eye[1], p->settings.eye_w = eye[2];
  p->settings.focal_depth = focal_depth;
  GST_OBJECT_UNLOCK(self);
  p->generation++;
  g_object_freeze_notify(G_OBJECT(self));
  for (GParamSpec* ps : {spec_eye_s, spec_eye_t, spec_eye_w, spec_focal_depth})
    g_object_notify_by_pspec(G_OBJECT(self), ps);
  g_object_thaw_notify(G_OBJECT(self));
}

static void handle_navigation(LfViewRequest* self, GstEvent* event) {
  Priv* p = self->priv;
  g_mutex_lock(&p->lock);
  State* st = p->state.get();
  // Every camera branch forwards the same event upstream: apply it once.
  const guint32 seq = gst_event_get_seqnum(event);
  if (!st || seq == st->last_seqnum) {
    g_mutex_unlock(&p->lock);
    return;
  }
  st->last_seqnum = seq;
  const std::shared_ptr<const lf::Rig> rig_ref = st->rig;
  const std::shared_ptr<const Views> views = st->views;
  const lf::Rig& rig = *rig_ref;
  const Settings s = lfgst::snapshot(GST_OBJECT(self), p->settings);
  const double step = rig.typical_spacing();
  lf::EyeAndFocus v{{s.eye_s, s.eye_t, s.eye_w}, s.focal_depth};
  double x = 0, y = 0, dx = 0, dy = 0;
  gint button = 0;
  const gchar* key = nullptr;
  bool changed = false, scroll = false;
  switch (gst_navigation_event_get_type(event)) {
    case GST_NAVIGATION_EVENT_MOUSE_BUTTON_PRESS:
      if (gst_navigation_event_parse_mouse_button_event(event, &button, &x, &y)) {
        // Click to focus: button 3 (right), or button 1 with Control.
        GstNavigationModifierType mods = GST_NAVIGATION_MODIFIER_NONE;
        gst_navigation_event_parse_modifier_state(event, &mods);
        if (button == 3 || (button == 1 && (mods & GST_NAVIGATION_MODIFIER_CONTROL_MASK))) {
          st->focus.click(x, y);
          GST_DEBUG_OBJECT(self, "click to focus at (%g, %g)", x, y);
          break;
        }
        if (button == 1) st->dragging = true, st->drag_x = x, st->drag_y = y;
        // X sinks (ximagesink, xvimagesink) send the wheel as buttons 4/5.
        if (button == 4 || button == 5) scroll = true, dy = button == 4 ? 1 : -1;
      }
      break;
    case GST_NAVIGATION_EVENT_MOUSE_BUTTON_RELEASE:
      if (gst_navigation_event_parse_mouse_button_event(event, &button, &x, &y) && button == 1)
        st->dragging = false;
      break;
    case GST_NAVIGATION_EVENT_MOUSE_MOVE:
      if (st->dragging && gst_navigation_event_parse_mouse_move_event(event, &x, &y)) {
        // Drag: move the eye on the camera plane, 1/40 camera spacing per pixel.
        lf::drag_moves_eye(x - st->drag_x, y - st->drag_y, step, &v);
        st->drag_x = x, st->drag_y = y;
        changed = true;
      }
      break;
    case GST_NAVIGATION_EVENT_MOUSE_SCROLL:
      scroll = gst_navigation_event_parse_mouse_scroll_event(event, &x, &y, &dx, &dy);
      break;
    case GST_NAVIGATION_EVENT_KEY_PRESS:
      if (gst_navigation_event_parse_key_event(event, &key) && key)
        changed = lf::key_moves_eye(key, step, &v);
      break;
    default:
      break;
  }
  if (scroll) {
    // Wheel: focal plane nearer/farther by 0.25 px of parallax between
    // neighbouring cameras per notch.
    const double q0 =
        v.focal_depth > 0 ? 1.0 / v.focal_depth : lf::inverse_depth_of(rig, views->plane);
    lf::wheel_moves_focus(dy, rig.cameras[0].intrinsics.fx, step, q0, MAX_COORD, &v);
    changed = true;
  }
  if (changed) {
    // Keep the eye over the camera array (off it the picture would be black).
    cv::Vec2d base(0, 0);
    if (s.position.size() == 3)
      base = rig.plane().to_plane({s.position[0], s.position[1], s.position[2]});
    const cv::Vec2d st2 = lf::clamp_to_array(rig, base + cv::Vec2d(v.eye[0], v.eye[1])) - base;
    v.eye[0] = st2[0], v.eye[1] = st2[1];
  }
  g_mutex_unlock(&p->lock);
  if (changed) {
    GST_DEBUG_OBJECT(self, "navigation: eye (s, t, w) = (%g, %g, %g), focal depth %g", v.eye[0],
                     v.eye[1], v.eye[2], v.focal_depth);
    set_navigated(self, v.eye, v.focal_depth);
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
  lfgst::read_view_change(st, G_OBJECT(self), MAX_COORD, &values, &why);
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
  const GstStructure* s = gst_event_get_structure(event);
  lfgst::FocusAnswer a;
  std::string why;
  if (!lfgst::read_focus(s, &a, &why)) {
    LF_ELEMENT_WARNING_LIMITED(self, p->bad_event, STREAM, FAILED,
                               ("Ignoring a malformed lf-focus event"), "%s", why.c_str());
    return;
  }
  const guint probe = a.probe;
  double q = a.inverse_depth;
  g_mutex_lock(&p->lock);
  State* st = p->state.get();
  const Settings v = lfgst::snapshot(GST_OBJECT(self), p->settings);
  const cv::Vec3d eye(v.eye_s, v.eye_t, v.eye_w);
  // Applied once, the last click's as it is, continuous ones part of the
  // way from the plane in use (lf::FocusSchedule::answer).
  const std::optional<double> to =
      st ? st->focus.answer(probe, q,
                            v.focal_depth > 0 ? 1.0 / v.focal_depth
                                              : lf::inverse_depth_of(*st->rig, st->views->plane))
         : std::nullopt;
  g_mutex_unlock(&p->lock);
  if (!to) return;
  q = *to;
  const double depth = q > 1.0 / MAX_COORD ? 1.0 / q : MAX_COORD;
  GST_DEBUG_OBJECT(self, "focused by probe %u: depth %g", probe, depth);
  set_navigated(self, eye, depth);
}

// An lf-surface event (lfcompositor's answer to a surface probe): the
// surface that the next requests carry, once per probe and never one older
// than the surface in use. Sizes are checked here, the surface against the
// view when a request takes it (lf::validate).
static void handle_surface_event(LfViewRequest* self, GstEvent* event) {
  Priv* p = self->priv;
  const GstStructure* s = gst_event_get_structure(event);
  lfgst::SurfaceAnswer a;
  std::string why;
  if (!lfgst::read_surface(s, &a, &why)) {
    LF_ELEMENT_WARNING_LIMITED(self, p->bad_event, STREAM, FAILED,
                               ("Ignoring a malformed lf-surface event"), "%s (gst/lfevents.h)",
                               why.c_str());
    return;
  }
  const guint probe = a.probe;
  g_mutex_lock(&p->lock);
  State* st = p->state.get();
  const bool fresh = st && st->surface.answer(probe, std::move(a.surface));
  g_cond_broadcast(&p->surface_cond);
  g_mutex_unlock(&p->lock);
  GST_DEBUG_OBJECT(self, "surface probe %u answered%s", probe, fresh ? "" : " (not ours or stale)");
}

static gboolean lf_view_request_event(GstBaseSrc* src, GstEvent* event) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  if (GST_EVENT_TYPE(event) == GST_EVENT_CUSTOM_UPSTREAM &&
      gst_event_has_name(event, "lf-surface")) {
    if (for_this_viewer(self, gst_event_get_structure(event))) handle_surface_event(self, event);
    return TRUE;
  }
  if (GST_EVENT_TYPE(event) == GST_EVENT_CUSTOM_UPSTREAM && gst_event_has_name(event, "lf-focus")) {
    if (for_this_viewer(self, gst_event_get_structure(event))) handle_focus_event(self, event);
    return TRUE;
  }
  if (GST_EVENT_TYPE(event) == GST_EVENT_NAVIGATION) {
    if (for_this_viewer(self, gst_event_get_structure(event))) handle_navigation(self, event);
    return TRUE;
  }
  if (GST_EVENT_TYPE(event) == GST_EVENT_CUSTOM_UPSTREAM && gst_event_has_name(event, "lf-view")) {
    if (for_this_viewer(self, gst_event_get_structure(event))) handle_view_event(self, event);
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
  if (!lfgst::guard(
          [&] {
            bytes = timed.size() == 1 ? lf::serialize_request(timed[0])
                                      : lf::serialize_probe_bundle(timed);
          },
          &err)) {
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

// The views for request time `pts`: controller values synced, rebuilt when
// a view property changed since the last request (a bad change is warned
// about and the previous views stay).
static std::shared_ptr<const Views> current_views(LfViewRequest* self, State* st,
                                                  GstClockTime pts) {
  Priv* p = self->priv;
  gst_object_sync_values(GST_OBJECT(self), pts);
  const guint gen = p->generation.load();
  if (gen != st->applied) {
    g_mutex_lock(&p->apply_lock);
    Settings s = lfgst::snapshot(GST_OBJECT(self), p->settings);
    g_mutex_unlock(&p->apply_lock);
    // Caps and schedule stay as started.
    s.rig = st->fixed.rig, s.viewer_id = st->fixed.viewer_id;
    s.width = st->fixed.width, s.height = st->fixed.height;
    s.framerate = st->fixed.framerate, s.live = st->fixed.live;
    std::shared_ptr<const Views> v;
    GError* err = nullptr;
    if (lfgst::guard([&] { v = build(s, *st->rig); }, &err)) {
      g_mutex_lock(&p->lock);
      st->views = v;
      g_mutex_unlock(&p->lock);
    } else {
      LF_ELEMENT_WARNING_LIMITED(self, p->bad_view, LIBRARY, SETTINGS,
                                 ("Ignoring invalid view settings; the previous view stays"), "%s",
                                 err->message);
      g_error_free(err);
    }
    st->applied = gen;
  }
  g_mutex_lock(&p->lock);
  std::shared_ptr<const Views> v = st->views;
  g_mutex_unlock(&p->lock);
  return v;
}

static GstFlowReturn lf_view_request_create(GstBaseSrc* src, guint64, guint, GstBuffer** out) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  Priv* p = self->priv;
  State* st = p->state.get();
  if (!st->rest_of_tick.empty()) {
    *out = st->rest_of_tick.front();
    st->rest_of_tick.pop_front();
    return GST_FLOW_OK;
  }
  const Settings& fixed = st->fixed;
  // Non-live: the first request after a surface probe waits for its answer
  // (at most kSurfaceWaitNonLive, once per probe), or a source that runs
  // ahead of the pipeline would make every request of a short run before
  // the answer came. Live sources never wait: the answer applies when it
  // comes.
  bool give_up_surface = false;  // non-live: the first probe had no answer
  if (!fixed.live) {
    g_mutex_lock(&p->lock);
    if (const auto id = st->surface.wait_for()) {
      const gint64 until = g_get_monotonic_time() + kSurfaceWaitNonLive / GST_USECOND;
      while (st->surface.awaiting() && !p->unlocked)
        if (!g_cond_wait_until(&p->surface_cond, &p->lock, until)) break;
      if (st->surface.awaiting())
        GST_DEBUG_OBJECT(self, "surface probe %u: no answer, going on", *id);
      if (!st->surface.ever_answered()) give_up_surface = true;
    }
    const bool unlocked = p->unlocked;
    g_mutex_unlock(&p->lock);
    if (unlocked) return GST_FLOW_FLUSHING;
  }
  const GstClockTime period =
      gst_util_uint64_scale_int(GST_SECOND, fixed.framerate.d, fixed.framerate.n);
  if (fixed.live)  // a viewer joining late starts at the current tick
    st->sequence = lfgst::first_current_tick(GST_ELEMENT(src), st->sequence, period, 0);
  const guint64 k = st->sequence;
  const GstClockTime pts = k * period;
  // Live: emit at running time pts on the pipeline clock.
  if (fixed.live && !p->waiter.wait_until(GST_ELEMENT(src), pts)) return GST_FLOW_FLUSHING;
  const std::shared_ptr<const Views> views = current_views(self, st, pts);
  const Settings& s = views->s;
  lf::ViewRequest req;
  req.viewer_id = fixed.viewer_id;
  req.sequence = k;
  req.focal_plane = views->plane;
  const lf::Rig& rig = *st->rig;
  GError* err = nullptr;
  if (!lfgst::guard(
          [&] {
            req.view =
                views->sequence.at(k, rig, lf::camera_plane_offset(rig, s.eye_s, s.eye_t, s.eye_w));
            lf::validate(req);
          },
          &err)) {
    LF_ELEMENT_WARNING_LIMITED(self, p->bad_view, LIBRARY, SETTINGS,
                               ("Ignoring the eye offset: the view it gives is invalid"), "%s",
                               err->message);
    g_error_free(err);
    req.view = views->sequence.at(k, rig);
  }
  // The aperture (its f-number needs the view's focal length) and sampling.
  if (s.ulr_cameras > 0) {
    req.aperture = lf::Aperture::kUlr;
    req.ulr_cameras = std::max<int>(lf::kMinUlrCameras, static_cast<int>(s.ulr_cameras));
  } else {
    req.aperture_scale = aperture_scale(self, rig, s, req.view);
  }
  req.sampling = s.sampling;
  // Focus and surface probes (lf::FocusSchedule, lf::SurfaceSchedule) go
  // with this tick's request, each probe in one buffer
  // (lib/lf/wire/probe_bundle.h).
  std::vector<std::vector<lf::ViewRequest>> probes;
  const bool continuous =
      lfgst::read_setting(GST_OBJECT(self), p->settings, &Settings::continuous_focus);
  // A quilt's eyes share one focal plane (lib/lf/render/quilt.h): no surface.
  const bool want_surface = s.quilt_views == 0 && lfgst::read_setting(GST_OBJECT(self), p->settings,
                                                                      &Settings::focal_surface);
  const double focal_depth =
      lfgst::read_setting(GST_OBJECT(self), p->settings, &Settings::focal_depth);
  const std::string focal_plane =
      lfgst::read_setting(GST_OBJECT(self), p->settings, &Settings::focal_plane);
  const guint interval =
      lfgst::read_setting(GST_OBJECT(self), p->settings, &Settings::surface_interval);
  g_mutex_lock(&p->lock);
  const guint64 retry_ticks =
      std::max<guint64>(kClickRetryTicks, (kClickRetryAfter + period - 1) / period);
  if (const auto fp =
          st->focus.probe_for(k, retry_ticks, continuous, req.view.width, req.view.height)) {
    GError* perr = nullptr;
    if (!lfgst::guard(
            [&] { probes.push_back(lf::focus_probe_requests(rig, req, fp->x, fp->y, fp->id)); },
            &perr)) {
      GST_WARNING_OBJECT(self, "no focus probe: %s", perr->message);
      g_error_free(perr);
    }
    GST_DEBUG_OBJECT(self, "%s focus probe %u at (%g, %g), request time %" GST_TIME_FORMAT,
                     fp->click ? "click" : "continuous", fp->id, fp->x, fp->y, GST_TIME_ARGS(pts));
  }
  // Focal surface: a probe every surface-interval ticks (the first at once),
  // of the view without its surface; the surface in use, if any, goes into
  // the request.
  const lf::SurfaceSchedule::Tick sp_tick = st->surface.tick(
      k, want_surface, focal_depth, focal_plane, interval, give_up_surface, g_get_monotonic_time());
  if (sp_tick.probe) {
    std::vector<lf::ViewRequest> sp;
    GError* perr = nullptr;
    if (lfgst::guard([&] { sp = lf::surface_probe_requests(rig, req, sp_tick.probe); }, &perr)) {
      probes.push_back(std::move(sp));
      GST_DEBUG_OBJECT(self, "surface probe %u, request time %" GST_TIME_FORMAT, sp_tick.probe,
                       GST_TIME_ARGS(pts));
    } else {
      GST_WARNING_OBJECT(self, "no surface probe: %s", perr->message);
      g_error_free(perr);
    }
  }
  const lf::FocalSurface surface = st->surface.surface();
  g_mutex_unlock(&p->lock);
  if (sp_tick.refocused) {
    GST_INFO_OBJECT(self, "refocused on a plane: focal-surface off");
    g_object_set(self, "focal-surface", FALSE, nullptr);
  }
  if (sp_tick.gave_up)
    GST_ELEMENT_WARNING(
        self, STREAM, FAILED, ("No answer to the focal surface probes: using focal-plane"),
        ("%u surface probes sent, none answered: no lfcompositor downstream in this pipeline "
         "answers them (across hosts, the compositor's answers cannot reach this element), or "
         "it could not estimate a surface (its warning says why); set focal-surface=false to "
         "focus on focal-plane without probing",
         st->surface.probes_sent()));
  guint surface_planes = 0, two_plane_tiles = 0;
  if (!surface.empty()) {
    lf::ViewRequest with = req;
    with.focal_plane = surface.planes[0];
    if (surface.planes_used() > 1) with.surface = surface;
    GError* serr = nullptr;
    if (lfgst::guard([&] { lf::validate(with); }, &serr)) {
      req = with;
      surface_planes = static_cast<guint>(surface.planes_used());
      two_plane_tiles = static_cast<guint>(req.surface.two_plane_tiles());
    } else {
      LF_ELEMENT_WARNING_LIMITED(self, p->bad_view, LIBRARY, SETTINGS,
                                 ("Ignoring a focal surface that does not fit the view"), "%s",
                                 serr->message);
      g_error_free(serr);
      g_mutex_lock(&p->lock);
      st->surface.drop_surface();
      g_mutex_unlock(&p->lock);
    }
  }
  GST_OBJECT_LOCK(self);
  p->settings.surface_planes = surface_planes;
  p->settings.surface_two_plane_tiles = two_plane_tiles;
  GST_OBJECT_UNLOCK(self);
  // The quilt's one request, or the stereo pair, or the view alone.
  lf::TickShape shape;
  if (s.quilt_views > 0) shape.quilt = quilt_of(s);
  shape.quilt_baseline = s.quilt_baseline, shape.view_cone = s.view_cone;
  shape.stereo_baseline = s.stereo_baseline;
  const std::vector<lf::ViewRequest> tick = lf::tick_requests(rig, req, shape);
  probes.erase(std::remove_if(probes.begin(), probes.end(),
                              [](const std::vector<lf::ViewRequest>& v) { return v.empty(); }),
               probes.end());
  // The tick's first request now, the others from the next calls, at once
  // (num-buffers counts ticks: the base class counts each call).
  std::vector<GstBuffer*> bufs;
  for (const lf::ViewRequest& r : tick) bufs.push_back(request_buffer(src, {r}, pts, period));
  for (std::vector<lf::ViewRequest>& probe : probes)
    bufs.push_back(request_buffer(src, std::move(probe), pts, period));
  bufs.erase(std::remove(bufs.begin(), bufs.end(), nullptr), bufs.end());
  if (bufs.empty()) {
    GST_ELEMENT_ERROR(self, LIBRARY, FAILED, ("Cannot serialize the view request"),
                      ("request %" G_GUINT64_FORMAT, req.sequence));
    return GST_FLOW_ERROR;
  }
  *out = bufs[0];
  st->rest_of_tick.insert(st->rest_of_tick.end(), bufs.begin() + 1, bufs.end());
  if (bufs.size() > 1) {
    g_mutex_lock(&src->live_lock);  // the base class reads it under this lock
    if (src->num_buffers_left >= 0) src->num_buffers_left += static_cast<gint>(bufs.size() - 1);
    g_mutex_unlock(&src->live_lock);
  }
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
  const GParamFlags rw = lfgst::kReadWriteReady;
  props.add(
      oc, &Settings::rig,
      g_param_spec_string("rig", "Rig", "Rig file (.json) or dataset folder (lf-render --input)",
                          nullptr, rw));
  props.add(oc, &Settings::viewer_id,
            g_param_spec_uint("viewer-id", "Viewer id", "Tag of this viewer's requests and output",
                              0, G_MAXUINT32, DEFAULT_VIEWER_ID, rw));
  props.add(
      oc, &Settings::width,
      g_param_spec_int("width", "Width", "Output width, pixels", 2, 16384, DEFAULT_WIDTH, rw));
  props.add(
      oc, &Settings::height,
      g_param_spec_int("height", "Height", "Output height, pixels", 2, 16384, DEFAULT_HEIGHT, rw));
  // View properties: changeable in PLAYING, from the next request on.
  const GParamFlags play = lfgst::kReadWritePlaying;
  const GParamFlags ctrl = static_cast<GParamFlags>(play | GST_PARAM_CONTROLLABLE);
  auto coordinate = [] {
    return g_param_spec_double(
        "coordinate", "Coordinate", "Rig units", -MAX_COORD, MAX_COORD, 0,
        static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS));
  };
  props.add(oc, &Settings::position,
            gst_param_spec_array("position", "Position",
                                 "Eye <x, y, z>, rig units, world frame (gst-launch: "
                                 "position=\"<0.1, 0, 0>\"; empty: the centroid of the camera "
                                 "centres). The eye offset eye-s/t/w is added to it",
                                 coordinate(), play));
  props.add(oc, &Settings::look_at,
            gst_param_spec_array("look-at", "Look at",
                                 "Target <x, y, z>, rig units, world frame (empty: look like the "
                                 "rig's cameras, with intrinsics interpolated from the "
                                 "surrounding ones)",
                                 coordinate(), play));
  spec_eye_s =
      g_param_spec_double("eye-s", "Eye s",
                          "Eye offset along the camera plane's u axis (its s "
                          "coordinate, lib/lf/geometry/rig.h), rig units; drag and arrow keys "
                          "change it",
                          -MAX_COORD, MAX_COORD, 0, ctrl);
  props.add(oc, &Settings::eye_s, spec_eye_s);
  spec_eye_t = g_param_spec_double("eye-t", "Eye t",
                                   "Eye offset along the camera plane's v axis (t), rig units",
                                   -MAX_COORD, MAX_COORD, 0, ctrl);
  props.add(oc, &Settings::eye_t, spec_eye_t);
  spec_eye_w = g_param_spec_double("eye-w", "Eye w",
                                   "Eye offset along the camera plane's normal, the way the "
                                   "cameras look (dolly), rig units; Page_Up/Page_Down change it",
                                   -MAX_COORD, MAX_COORD, 0, ctrl);
  props.add(oc, &Settings::eye_w, spec_eye_w);
  props.add(oc, &Settings::vfov,
            g_param_spec_double(
                "vfov", "Vertical FOV",
                "Vertical field of view, degrees (0: from the cameras, or 50 with look-at)", 0,
                179.9, DEFAULT_VFOV, ctrl));
  props.add(oc, &Settings::focal_plane,
            g_param_spec_string("focal-plane", "Focal plane",
                                "infinity | depth:Z (rig units from the camera plane) | param:A "
                                "(light-slab focal parameter, pixels of shift per unit) | "
                                "plane:nx,ny,nz,d (world frame, n.X + d = 0); used while "
                                "focal-depth is 0",
                                DEFAULT_FOCAL_PLANE, play));
  props.add(oc, &Settings::continuous_focus,
            g_param_spec_boolean(
                "continuous-focus", "Continuous focus",
                "Keep focusing at the last clicked point (the view centre before any click): "
                "a focus probe every 5 requests, each answer moving the focal plane half way "
                "(in inverse depth)",
                FALSE, play));
  props.add(
      oc, &Settings::focal_surface,
      g_param_spec_boolean(
          "focal-surface", "Focal surface",
          "Focus each 16-pixel tile of the view on its own plane, estimated from the "
          "cameras' fragments (lib/lf/focus/surface_probe.h): every surface-interval requests a "
          "surface probe (32 requests for the view at 160 pixels wide, one per candidate "
          "plane, in one buffer) goes out with the request, lfcompositor estimates the "
          "surface from the answers and sends it back (an lf-surface event), and the "
          "requests carry it "
          "from then on (view request version 3) in place of focal-plane and focal-depth. "
          "false: the paper's one focal plane per view (focal-plane, focal-depth); "
          "refocusing while playing (the wheel, a click, focal-depth or focal-plane set) "
          "sets it false. Without "
          "an lfcompositor downstream in this pipeline to answer, the probes stop after "
          "the first few, with a warning, and focal-plane is used",
          TRUE, play));
  props.add(oc, &Settings::surface_interval,
            g_param_spec_uint("surface-interval", "Surface interval",
                              "Requests from one surface probe to the next with focal-surface "
                              "(in between, the view keeps the last surface: meant for a steady "
                              "or slowly moving view)",
                              1, G_MAXINT32, DEFAULT_SURFACE_INTERVAL, play));
  props.add(oc, &Settings::surface_planes,
            g_param_spec_uint("surface-planes", "Surface planes",
                              "Distinct planes of the focal surface in the last request (0: "
                              "none, the focal plane)",
                              0, lf::FocalSurface::kMaxPlanes, 0,
                              static_cast<GParamFlags>(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  props.add(oc, &Settings::surface_two_plane_tiles,
            g_param_spec_uint("surface-two-plane-tiles", "Two-plane tiles",
                              "Tiles of the focal surface in the last request that have a second "
                              "plane (lfcompositor second-planes: their cameras send them twice)",
                              0, G_MAXUINT, 0,
                              static_cast<GParamFlags>(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  spec_focal_depth = g_param_spec_double(
      "focal-depth", "Focal depth",
      "Focal plane parallel to the camera plane at this depth, rig units along its normal "
      "(0: use focal-plane); the wheel changes it",
      0, MAX_COORD, DEFAULT_FOCAL_DEPTH, ctrl);
  props.add(oc, &Settings::focal_depth, spec_focal_depth);
  props.add(oc, &Settings::aperture,
            g_param_spec_double(
                "aperture", "Aperture",
                "Synthetic aperture diameter on the camera plane, rig units (Isaksen et al. "
                "2000): the paper's tent spans 2 camera spacings and is the smallest (0 or "
                "anything up to it: the tent); wider apertures blend more cameras, so what is "
                "off the focal plane blurs instead of doubling, at more fragment pixels "
                "(up to 16 tents wide)",
                0, MAX_COORD, 0, ctrl));
  props.add(oc, &Settings::f_number,
            g_param_spec_double(
                "f-number", "f-number",
                "Aperture as a full-frame-equivalent f-number, overriding aperture when > 0: "
                "N = F / D with F = 36 mm x fx / width, the focal length of a 36 mm wide sensor "
                "with the view's field of view (such a lens at f/N, focused on the focal plane, "
                "blurs as this aperture does); needs the rig's unit to be mm, cm or m",
                0, 1e6, 0, ctrl));
  props.add(
      oc, &Settings::ulr_cameras,
      g_param_spec_uint(
          "ulr-cameras", "ULR cameras",
          "Unstructured Lumigraph weights (Buehler et al. 2001, lib/lf/geometry/view.h) blending "
          "the "
          "k cameras nearest each ray in angle, for rigs without a grid and so that a lost "
          "camera leaves no hole; 0: the tent (aperture, f-number apply), else k (1 counts as 2)",
          0, lf::kMaxUlrCameras, 0, ctrl));
  props.add(oc, &Settings::sampling,
            g_param_spec_enum("sampling", "Sampling",
                              "How the cameras resample their images into fragments (the "
                              "requests carry it; focus and surface probes stay bilinear)",
                              LF_TYPE_SAMPLING, static_cast<gint>(lf::Sampling::kBilinear), ctrl));
  props.add(
      oc, &Settings::path,
      g_param_spec_string("path", "Camera path",
                          "Keyframed camera path (JSON, docs/rendering.md); overrides position",
                          nullptr, play));
  props.add(oc, &Settings::orbit,
            g_param_spec_double("orbit", "Orbit",
                                "Circular path on the camera plane, radius as a fraction of the "
                                "array's half extent (0: off)",
                                0, 10, DEFAULT_ORBIT, play));
  props.add(oc, &Settings::dolly,
            g_param_spec_double(
                "dolly", "Dolly",
                "With orbit: amplitude of motion along the camera-plane normal, rig units",
                -MAX_COORD, MAX_COORD, DEFAULT_DOLLY, play));
  props.add(oc, &Settings::path_frames,
            g_param_spec_int("path-frames", "Path frames", "Requests per pass over the path/orbit",
                             1, 1000000, DEFAULT_PATH_FRAMES, play));
  props.add(oc, &Settings::framerate,
            gst_param_spec_fraction("framerate", "Frame rate",
                                    "Requests per second (also in the src caps)", 1, 1000, 1000, 1,
                                    DEFAULT_FPS_N, DEFAULT_FPS_D, rw));
  props.add(
      oc, &Settings::live,
      g_param_spec_boolean("is-live", "Live", "Emit requests in real time on the pipeline clock",
                           DEFAULT_IS_LIVE, rw));
  props.add(oc, &Settings::stereo_baseline,
            g_param_spec_double("stereo-baseline", "Stereo baseline",
                                "Eye separation in rig units; > 0 emits a left (viewer-id) and a "
                                "right (viewer-id + 1) request per tick, for lfcompositor "
                                "stereo=true",
                                0, MAX_COORD, DEFAULT_STEREO_BASELINE, ctrl));
  props.add(oc, &Settings::quilt_views,
            g_param_spec_uint(
                "quilt-views", "Quilt views",
                "0: one view. 2..128: a quilt for a light-field display (docs/displays.md): this "
                "many eyes along the view's x axis, each answered by every camera in the same "
                "request round, tiled in the width x height frame in quilt-columns x "
                "quilt-rows tiles, the first (leftmost) eye at the bottom-left, then left to "
                "right and upward; the eyes share the focal plane (no focal surface)",
                0, lf::Quilt::kMaxViews, 0, rw));
  props.add(oc, &Settings::quilt_cols,
            g_param_spec_uint("quilt-columns", "Quilt columns",
                              "Tiles across the quilt; width must be a multiple", 1,
                              lf::Quilt::kMaxTiles, 8, rw));
  props.add(oc, &Settings::quilt_rows,
            g_param_spec_uint("quilt-rows", "Quilt rows",
                              "Tiles down the quilt; height must be a multiple", 1,
                              lf::Quilt::kMaxTiles, 6, rw));
  props.add(oc, &Settings::view_cone,
            g_param_spec_double("view-cone", "View cone",
                                "Quilt: the angle (degrees) between the first and the last eye "
                                "seen from the focal plane's point on the view axis (a "
                                "display's view cone, e.g. 40); 0: the baseline is the camera "
                                "array's width along the view's x axis (all the parallax it "
                                "captured, none made up). quilt-baseline, if set, wins",
                                0, 120, 0, ctrl));
  props.add(oc, &Settings::quilt_baseline,
            g_param_spec_double("quilt-baseline", "Quilt baseline",
                                "Quilt: first eye to last in rig units; 0: from view-cone (one "
                                "camera spacing where the cone is focused at infinity)",
                                0, MAX_COORD, 0, ctrl));
  gst_element_class_add_static_pad_template(ec, &src_template);
  gst_element_class_set_static_metadata(
      ec, "Light field view requests", "Source/Metadata",
      "Produces view requests (virtual view + focal plane) for the light field cameras "
      "(Yang et al. 2002, 4.3). View properties change while playing; an upstream 'lf-view' "
      "event sets several at once. Navigation from the video sink: drag (button 1) moves the "
      "eye on the camera plane, the wheel (buttons 4/5) the focal plane, arrow keys the eye by "
      "1/4 camera spacing, Page_Up/Page_Down (Prior/Next, +/-) along the normal, r resets",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess orbit=0.5 "
      "num-buffers=60 ! lfarray rig=../shared/data/stanford-chess ! videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Upstream custom events it takes: lf-view (any view property as a field of the same name and "
      "type, and viewer-id, uint: applied whole, or refused with a warning message naming the bad "
      "field), lf-focus and lf-surface (lfcompositor's answers to its probes), and navigation "
      "events (drag, wheel, keys, click to focus). An error message at READY for each bad property "
      "value; a warning when the focal plane lies behind the cameras.");
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
