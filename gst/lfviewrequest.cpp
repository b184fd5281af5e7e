/**
 * SECTION:element-lfviewrequest
 * @title: lfviewrequest
 *
 * Produces view requests (Yang et al. 2002, Section 4.3: a virtual view and a
 * focal plane) at a rate, for one viewer: a fixed view from the properties, a
 * keyframed camera path (`path`) or an orbit over the camera plane (`orbit`).
 * Output: `application/x-lf-view-request` buffers (byte layout in
 * lib/lf/wire.h) whose caps carry the request `framerate`. Positions are in
 * the rig's units and world frame (lib/lf/rig.h). Views are built by
 * lib/lf/view_builder.h, as `lf-render` builds them.
 *
 * Navigation events from the video sink steer the view: drag (button 1)
 * moves the eye on the camera plane, the wheel moves the focal plane (0.25 px
 * of neighbour parallax per notch), arrow keys move the eye by 1/4 camera
 * spacing, Page_Up/Page_Down (or +/-) move it along the camera-plane normal,
 * r resets.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=rig.json position=0,0,0 focal-plane=depth:2 num-buffers=1 ! \
 *   fakesink dump=true
 * ]|
 */
#include <gst/base/gstbasesrc.h>
#include <gst/video/navigation.h>

#include <memory>
#include <vector>

#include "lf/focus.h"
#include "lf/parse.h"
#include "lf/view_builder.h"
#include "lf/wire.h"
#include "lfcaps.h"
#include "lfclock.h"
#include "lfguard.h"
#include "lfprops.h"
#include "lfrig.h"
#include "lftrace.h"

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
#define DEFAULT_ORBIT 0.0
#define DEFAULT_DOLLY 0.0
#define DEFAULT_PATH_FRAMES 120
#define DEFAULT_FPS_N 30
#define DEFAULT_FPS_D 1
#define DEFAULT_IS_LIVE FALSE
#define DEFAULT_STEREO_BASELINE 0.0

namespace {
struct Settings {
  std::string rig;
  guint viewer_id = DEFAULT_VIEWER_ID;
  gint width = DEFAULT_WIDTH, height = DEFAULT_HEIGHT;
  std::string position, look_at;
  gdouble vfov = DEFAULT_VFOV;
  std::string focal_plane = DEFAULT_FOCAL_PLANE;
  std::string path;
  gdouble orbit = DEFAULT_ORBIT, dolly = DEFAULT_DOLLY;
  gint path_frames = DEFAULT_PATH_FRAMES;
  lfgst::Fraction framerate{DEFAULT_FPS_N, DEFAULT_FPS_D};
  bool live = DEFAULT_IS_LIVE;
  gdouble stereo_baseline = DEFAULT_STEREO_BASELINE;
};

// From READY->PAUSED to PAUSED->READY.
struct State {
  Settings s;  // snapshot taken at start
  std::shared_ptr<const lf::Rig> rig;
  lf::ViewSequence views;
  lf::FocalPlane plane;
  guint64 sequence = 0;
  // Interactive state (navigation events), guarded by Priv::lock.
  cv::Vec3d offset = {0, 0, 0};  // added to the eye, rig units
  double q = 0;                  // focal inverse depth once the wheel was used
  bool q_active = false;
  bool dragging = false;
  double drag_x = 0, drag_y = 0;
  guint32 last_seqnum = GST_SEQNUM_INVALID;
};

struct Priv {
  Settings settings;  // properties (object lock)
  GMutex lock;        // guards `state` against the navigation (event) thread
  std::unique_ptr<State> state;
  lfgst::ClockWaiter waiter;
  Priv() { g_mutex_init(&lock); }
  ~Priv() { g_mutex_clear(&lock); }
};

lfgst::Properties<Settings> props;
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
}
LF_DEFINE_ELEMENT_GLUE(lf_view_request, LF_VIEW_REQUEST)

static lf::ViewSettings view_settings(const Settings& s) {
  lf::ViewSettings v;
  v.width = s.width;
  v.height = s.height;
  if (!s.position.empty()) v.position = lf::parse_point(s.position, "position");
  if (!s.look_at.empty()) v.look_at = lf::parse_point(s.look_at, "look-at");
  v.vfov_deg = s.vfov;
  v.path_file = s.path;
  v.orbit = s.orbit;
  v.dolly = s.dolly;
  v.path_frames = s.path_frames;
  return v;
}

static gboolean lf_view_request_start(GstBaseSrc* src) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  auto st = std::make_unique<State>();
  st->s = lfgst::snapshot(GST_OBJECT(self), self->priv->settings);
  if (st->s.framerate.n <= 0 || st->s.framerate.d <= 0) {
    GST_ELEMENT_ERROR(
        self, LIBRARY, SETTINGS, ("Invalid framerate"),
        ("framerate must be positive, got %d/%d", st->s.framerate.n, st->s.framerate.d));
    return FALSE;
  }
  st->rig = lfgst::open_rig(GST_ELEMENT(self), st->s.rig);
  if (!st->rig) return FALSE;
  GError* err = nullptr;
  if (!lfgst::guard(
          [&] {
            st->plane = lf::parse_focal_plane(st->s.focal_plane, *st->rig);
            st->views = lf::build_views(*st->rig, view_settings(st->s));
          },
          &err)) {
    GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Invalid view request settings"),
                      ("%s", err->message));
    g_error_free(err);
    return FALSE;
  }
  g_mutex_lock(&self->priv->lock);
  self->priv->state = std::move(st);
  g_mutex_unlock(&self->priv->lock);
  return TRUE;
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
  LF_VIEW_REQUEST(src)->priv->waiter.unlock();
  return TRUE;
}

static gboolean lf_view_request_unlock_stop(GstBaseSrc* src) {
  LF_VIEW_REQUEST(src)->priv->waiter.unlock_stop();
  return TRUE;
}

static void handle_navigation(LfViewRequest* self, GstEvent* event) {
  Priv* p = self->priv;
  g_mutex_lock(&p->lock);
  State* st = p->state.get();
  if (!st) {
    g_mutex_unlock(&p->lock);
    return;
  }
  const lf::Rig& rig = *st->rig;
  const double step = rig.typical_spacing();
  const lf::CameraPlane& P = rig.plane();
  double x = 0, y = 0, dx = 0, dy = 0;
  gint button = 0;
  const gchar* key = nullptr;
  // Every camera branch forwards the same event upstream: apply it once.
  const guint32 seq = gst_event_get_seqnum(event);
  if (seq == st->last_seqnum) {
    g_mutex_unlock(&p->lock);
    return;
  }
  st->last_seqnum = seq;
  switch (gst_navigation_event_get_type(event)) {
    case GST_NAVIGATION_EVENT_MOUSE_BUTTON_PRESS:
      if (gst_navigation_event_parse_mouse_button_event(event, &button, &x, &y) && button == 1)
        st->dragging = true, st->drag_x = x, st->drag_y = y;
      break;
    case GST_NAVIGATION_EVENT_MOUSE_BUTTON_RELEASE:
      if (gst_navigation_event_parse_mouse_button_event(event, &button, &x, &y) && button == 1)
        st->dragging = false;
      break;
    case GST_NAVIGATION_EVENT_MOUSE_MOVE:
      if (st->dragging && gst_navigation_event_parse_mouse_move_event(event, &x, &y)) {
        // Drag: move the eye on the camera plane, 1/40 camera spacing per pixel.
        st->offset -= (P.u * (x - st->drag_x) + P.v * (y - st->drag_y)) * (step / 40.0);
        st->drag_x = x, st->drag_y = y;
      }
      break;
    case GST_NAVIGATION_EVENT_MOUSE_SCROLL:
      if (gst_navigation_event_parse_mouse_scroll_event(event, &x, &y, &dx, &dy)) {
        // Wheel: focal plane nearer/farther by 0.25 px of parallax between
        // neighbouring cameras per notch.
        if (!st->q_active) st->q = lf::inverse_depth_of(rig, st->plane), st->q_active = true;
        const double f = rig.cameras[0].intrinsics.fx;
        st->q = std::max(0.0, st->q + dy * 0.25 / (f * step));
      }
      break;
    case GST_NAVIGATION_EVENT_KEY_PRESS:
      if (gst_navigation_event_parse_key_event(event, &key) && key) {
        const std::string k = key;
        if (k == "Left")
          st->offset -= P.u * (step / 4);
        else if (k == "Right")
          st->offset += P.u * (step / 4);
        else if (k == "Up")
          st->offset -= P.v * (step / 4);
        else if (k == "Down")
          st->offset += P.v * (step / 4);
        else if (k == "Page_Up" || k == "plus")
          st->offset += P.normal * step;
        else if (k == "Page_Down" || k == "minus")
          st->offset -= P.normal * step;
        else if (k == "r")
          st->offset = {0, 0, 0}, st->q_active = false;
      }
      break;
    default:
      break;
  }
  GST_DEBUG_OBJECT(self, "navigation: eye offset (%g, %g, %g), focal q %g", st->offset[0],
                   st->offset[1], st->offset[2], st->q_active ? st->q : -1.0);
  g_mutex_unlock(&p->lock);
}

static gboolean lf_view_request_event(GstBaseSrc* src, GstEvent* event) {
  if (GST_EVENT_TYPE(event) == GST_EVENT_NAVIGATION) {
    handle_navigation(LF_VIEW_REQUEST(src), event);
    return TRUE;
  }
  if (lfgst::refuse_seek(GST_ELEMENT(src), event)) return FALSE;
  return GST_BASE_SRC_CLASS(lf_view_request_parent_class)->event(src, event);
}

static GstBuffer* request_buffer(GstBaseSrc* src, const lf::ViewRequest& req, GstClockTime pts,
                                 GstClockTime period) {
  lfgst::trace(GST_ELEMENT(src), "issue", req.viewer_id, req.sequence, -1,
               static_cast<gint64>(pts));
  const std::vector<uint8_t> bytes = lf::serialize_request(req);
  GstBuffer* buf = gst_buffer_new_memdup(bytes.data(), bytes.size());
  GST_BUFFER_PTS(buf) = pts;
  GST_BUFFER_DTS(buf) = pts;
  GST_BUFFER_DURATION(buf) = period;
  GST_BUFFER_OFFSET(buf) = req.sequence;
  return buf;
}

static GstFlowReturn lf_view_request_create(GstBaseSrc* src, guint64, guint, GstBuffer** out) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  Priv* p = self->priv;
  State* st = p->state.get();
  const Settings& s = st->s;
  const GstClockTime period = gst_util_uint64_scale_int(GST_SECOND, s.framerate.d, s.framerate.n);
  if (s.live)  // a viewer joining late starts at the current tick
    st->sequence = lfgst::first_current_tick(GST_ELEMENT(src), st->sequence, period, 0);
  const guint64 k = st->sequence;
  const GstClockTime pts = k * period;
  // Live: emit at running time pts on the pipeline clock.
  if (s.live && !p->waiter.wait_until(GST_ELEMENT(src), pts)) return GST_FLOW_FLUSHING;
  lf::ViewRequest req;
  req.viewer_id = s.viewer_id;
  req.sequence = k;
  const lf::Rig& rig = *st->rig;
  g_mutex_lock(&p->lock);
  const cv::Vec3d offset = st->offset;
  const bool q_active = st->q_active;
  const double q = st->q;
  g_mutex_unlock(&p->lock);
  GError* err = nullptr;
  if (!lfgst::guard(
          [&] {
            req.view = st->views.at(k, rig, offset);
            req.focal_plane = q_active ? lf::plane_at_inverse_depth(rig, q) : st->plane;
          },
          &err)) {
    GST_ELEMENT_ERROR(self, LIBRARY, FAILED, ("Cannot build view request %" G_GUINT64_FORMAT, k),
                      ("%s", err->message));
    g_error_free(err);
    return GST_FLOW_ERROR;
  }
  if (s.stereo_baseline > 0) {
    // Left and right eyes along the view's x axis (viewer ids v, v + 1).
    const cv::Vec3d x(req.view.R(0, 0), req.view.R(0, 1), req.view.R(0, 2));
    lf::ViewRequest right = req;
    right.viewer_id = s.viewer_id + 1;
    right.view.position += x * (0.5 * s.stereo_baseline);
    req.view.position -= x * (0.5 * s.stereo_baseline);
    // One tick = one buffer list (num-buffers counts ticks).
    GstBufferList* list = gst_buffer_list_new_sized(2);
    gst_buffer_list_add(list, request_buffer(src, req, pts, period));
    gst_buffer_list_add(list, request_buffer(src, right, pts, period));
    gst_base_src_submit_buffer_list(src, list);
    *out = nullptr;
  } else {
    *out = request_buffer(src, req, pts, period);
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
  props.add(oc, &Settings::position,
            g_param_spec_string("position", "Position",
                                "Eye 'x,y,z' in rig units (empty: centre of the camera plane)",
                                nullptr, rw));
  props.add(oc, &Settings::look_at,
            g_param_spec_string("look-at", "Look at",
                                "Target 'x,y,z' in rig units (empty: look like the rig's cameras, "
                                "with intrinsics interpolated from the surrounding ones)",
                                nullptr, rw));
  props.add(oc, &Settings::vfov,
            g_param_spec_double(
                "vfov", "Vertical FOV",
                "Vertical field of view, degrees (0: from the cameras, or 50 with look-at)", 0,
                179.9, DEFAULT_VFOV, rw));
  props.add(oc, &Settings::focal_plane,
            g_param_spec_string("focal-plane", "Focal plane",
                                "infinity | depth:Z (rig units from the camera plane) | param:A "
                                "(light-slab focal parameter, pixels of shift per unit) | "
                                "plane:nx,ny,nz,d",
                                DEFAULT_FOCAL_PLANE, rw));
  props.add(oc, &Settings::path,
            g_param_spec_string("path", "Camera path",
                                "Keyframed camera path (JSON, see README); overrides position",
                                nullptr, rw));
  props.add(oc, &Settings::orbit,
            g_param_spec_double("orbit", "Orbit",
                                "Circular path on the camera plane, radius as a fraction of the "
                                "array's half extent (0: off)",
                                0, 10, DEFAULT_ORBIT, rw));
  props.add(oc, &Settings::dolly,
            g_param_spec_double(
                "dolly", "Dolly",
                "With orbit: amplitude of motion along the camera-plane normal, rig units", -1e12,
                1e12, DEFAULT_DOLLY, rw));
  props.add(oc, &Settings::path_frames,
            g_param_spec_int("path-frames", "Path frames", "Requests per pass over the path/orbit",
                             1, 1000000, DEFAULT_PATH_FRAMES, rw));
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
                                0, 1e12, DEFAULT_STEREO_BASELINE, rw));
  gst_element_class_add_static_pad_template(ec, &src_template);
  gst_element_class_set_static_metadata(
      ec, "Light field view requests", "Source/Metadata",
      "Produces view requests (virtual view + focal plane) for the light field cameras "
      "(Yang et al. 2002, 4.3). Navigation events from the video sink steer the view: drag "
      "(button 1) moves the eye on the camera plane, the wheel moves the focal plane (0.25 px "
      "of neighbour parallax per notch), arrow keys move the eye by 1/4 camera spacing, "
      "Page_Up/Page_Down (or +/-) move it along the camera-plane normal, r resets",
      "lightfield-gst");
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
