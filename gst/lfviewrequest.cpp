// lfviewrequest: produces view requests (Yang et al. 2002, Section 4.3) at a
// rate, for one viewer: a fixed view from properties, a keyframed camera path
// or an orbit. Output: application/x-lf-view-request buffers (lib/lf/wire.h).
#include <gst/base/gstbasesrc.h>
#include <gst/video/navigation.h>

#include <memory>
#include <vector>

#include "lf/composite.h"
#include "lf/focus.h"
#include "lf/parse.h"
#include "lf/path_file.h"
#include "lf/quality.h"
#include "lf/render.h"
#include "lf/render_view.h"
#include "lf/view_builder.h"
#include "lf/wire.h"
#include "lfcommon.h"

GST_DEBUG_CATEGORY_STATIC(lf_view_request_debug);
#define GST_CAT_DEFAULT lf_view_request_debug

G_BEGIN_DECLS
#define LF_TYPE_VIEW_REQUEST (lf_view_request_get_type())
G_DECLARE_FINAL_TYPE(LfViewRequest, lf_view_request, LF, VIEW_REQUEST, GstBaseSrc)
G_END_DECLS

namespace {
struct State {
  std::shared_ptr<const lf::Rig> rig;
  std::vector<lf::VirtualView> views;  // one per path frame (size 1 for a fixed view)
  lf::FocalPlane plane;
  guint64 sequence = 0;
  bool fixed_between_cameras = false;  // fixed view that follows the cameras' look
  // Interactive state (navigation events), guarded by the element's lock.
  cv::Vec3d offset = {0, 0, 0};  // added to the eye, rig units
  double q = 0;                  // focal inverse depth once the wheel was used
  bool q_active = false;
  bool dragging = false;
  double drag_x = 0, drag_y = 0;
  guint32 last_seqnum = GST_SEQNUM_INVALID;
};
}  // namespace

struct _LfViewRequest {
  GstBaseSrc parent;
  gchar* rig;
  guint viewer_id;
  gint width, height;
  gchar* position;
  gchar* look_at;
  gdouble vfov;
  gchar* focal_plane;
  gchar* path;
  gdouble orbit, dolly;
  gint path_frames;
  gint fps_n, fps_d;
  gboolean live;
  gdouble stereo_baseline;
  GMutex lock;
  lfgst::ClockWaiter* waiter;
  State* state;
};

enum {
  PROP_0,
  PROP_RIG,
  PROP_VIEWER_ID,
  PROP_WIDTH,
  PROP_HEIGHT,
  PROP_POSITION,
  PROP_LOOK_AT,
  PROP_VFOV,
  PROP_FOCAL_PLANE,
  PROP_PATH,
  PROP_ORBIT,
  PROP_DOLLY,
  PROP_PATH_FRAMES,
  PROP_FRAMERATE,
  PROP_IS_LIVE,
  PROP_STEREO_BASELINE,
};

G_DEFINE_TYPE(LfViewRequest, lf_view_request, GST_TYPE_BASE_SRC)

static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_REQUEST_CAPS));

static void set_string(gchar** field, const GValue* v) {
  g_free(*field);
  *field = g_value_dup_string(v);
}

static void lf_view_request_set_property(GObject* obj, guint id, const GValue* v, GParamSpec* ps) {
  LfViewRequest* self = LF_VIEW_REQUEST(obj);
  GST_OBJECT_LOCK(self);
  switch (id) {
    case PROP_RIG:
      set_string(&self->rig, v);
      break;
    case PROP_VIEWER_ID:
      self->viewer_id = g_value_get_uint(v);
      break;
    case PROP_WIDTH:
      self->width = g_value_get_int(v);
      break;
    case PROP_HEIGHT:
      self->height = g_value_get_int(v);
      break;
    case PROP_POSITION:
      set_string(&self->position, v);
      break;
    case PROP_LOOK_AT:
      set_string(&self->look_at, v);
      break;
    case PROP_VFOV:
      self->vfov = g_value_get_double(v);
      break;
    case PROP_FOCAL_PLANE:
      set_string(&self->focal_plane, v);
      break;
    case PROP_PATH:
      set_string(&self->path, v);
      break;
    case PROP_ORBIT:
      self->orbit = g_value_get_double(v);
      break;
    case PROP_DOLLY:
      self->dolly = g_value_get_double(v);
      break;
    case PROP_PATH_FRAMES:
      self->path_frames = g_value_get_int(v);
      break;
    case PROP_FRAMERATE:
      self->fps_n = gst_value_get_fraction_numerator(v);
      self->fps_d = gst_value_get_fraction_denominator(v);
      break;
    case PROP_IS_LIVE:
      self->live = g_value_get_boolean(v);
      break;
    case PROP_STEREO_BASELINE:
      self->stereo_baseline = g_value_get_double(v);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, ps);
  }
  GST_OBJECT_UNLOCK(self);
  // Must be known before READY->PAUSED (live sources do not preroll);
  // set_live takes the object lock itself.
  if (id == PROP_IS_LIVE) gst_base_src_set_live(GST_BASE_SRC(self), g_value_get_boolean(v));
}

static void lf_view_request_get_property(GObject* obj, guint id, GValue* v, GParamSpec* ps) {
  LfViewRequest* self = LF_VIEW_REQUEST(obj);
  GST_OBJECT_LOCK(self);
  switch (id) {
    case PROP_RIG:
      g_value_set_string(v, self->rig);
      break;
    case PROP_VIEWER_ID:
      g_value_set_uint(v, self->viewer_id);
      break;
    case PROP_WIDTH:
      g_value_set_int(v, self->width);
      break;
    case PROP_HEIGHT:
      g_value_set_int(v, self->height);
      break;
    case PROP_POSITION:
      g_value_set_string(v, self->position);
      break;
    case PROP_LOOK_AT:
      g_value_set_string(v, self->look_at);
      break;
    case PROP_VFOV:
      g_value_set_double(v, self->vfov);
      break;
    case PROP_FOCAL_PLANE:
      g_value_set_string(v, self->focal_plane);
      break;
    case PROP_PATH:
      g_value_set_string(v, self->path);
      break;
    case PROP_ORBIT:
      g_value_set_double(v, self->orbit);
      break;
    case PROP_DOLLY:
      g_value_set_double(v, self->dolly);
      break;
    case PROP_PATH_FRAMES:
      g_value_set_int(v, self->path_frames);
      break;
    case PROP_FRAMERATE:
      gst_value_set_fraction(v, self->fps_n, self->fps_d);
      break;
    case PROP_IS_LIVE:
      g_value_set_boolean(v, self->live);
      break;
    case PROP_STEREO_BASELINE:
      g_value_set_double(v, self->stereo_baseline);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, ps);
  }
  GST_OBJECT_UNLOCK(self);
}

static gboolean lf_view_request_start(GstBaseSrc* src) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  if (!self->rig || !*self->rig) {
    GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("No rig given"),
                      ("set the 'rig' property to a rig file or dataset folder"));
    return FALSE;
  }
  if (self->fps_n <= 0 || self->fps_d <= 0) {
    GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Invalid framerate"),
                      ("framerate must be positive, got %d/%d", self->fps_n, self->fps_d));
    return FALSE;
  }
  auto* st = new State();
  try {
    st->rig = lfgst::load_rig_cached(self->rig);
    const lf::Rig& rig = *st->rig;
    st->plane = lf::parse_focal_plane(self->focal_plane ? self->focal_plane : "infinity", rig);
    const int W = self->width, H = self->height;
    if (self->path && *self->path) {
      const auto keys = lf::load_path(self->path);
      st->views = lf::sample_path(rig, keys, std::max(1, self->path_frames), W, H, false);
    } else if (self->orbit > 0) {
      const auto keys = lf::orbit_path(rig, self->orbit, self->dolly, 24);
      st->views = lf::sample_path(rig, keys, std::max(1, self->path_frames), W, H, true);
    } else {
      cv::Vec3d eye = rig.plane().origin;
      if (self->position && *self->position && !lfgst::parse_vec3(self->position, eye))
        throw std::invalid_argument(std::string("position '") + self->position +
                                    "' is not 'x,y,z'");
      cv::Vec3d target;
      if (self->look_at && *self->look_at) {
        if (!lfgst::parse_vec3(self->look_at, target))
          throw std::invalid_argument(std::string("look-at '") + self->look_at +
                                      "' is not 'x,y,z'");
        const cv::Matx33d& R = rig.cameras[0].extrinsics.R;
        st->views.push_back(lf::VirtualView::look_at(eye, target, {R(1, 0), R(1, 1), R(1, 2)},
                                                     self->vfov > 0 ? self->vfov : 50.0, W, H));
      } else {
        st->views.push_back(lf::view_between_cameras(rig, eye, W, H));
        if (self->vfov > 0) st->views.back().vfov_deg = self->vfov;
        st->fixed_between_cameras = self->vfov <= 0;
      }
    }
    lf::ViewRequest probe;
    probe.view = st->views.front();
    probe.focal_plane = st->plane;
    lf::validate(probe);
  } catch (const std::exception& e) {
    delete st;
    GST_ELEMENT_ERROR(self, LIBRARY, SETTINGS, ("Invalid view request settings"), ("%s", e.what()));
    return FALSE;
  }
  delete self->state;
  self->state = st;
  return TRUE;
}

static gboolean lf_view_request_stop(GstBaseSrc* src) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  delete self->state;
  self->state = nullptr;
  return TRUE;
}

static gboolean lf_view_request_unlock(GstBaseSrc* src) {
  LF_VIEW_REQUEST(src)->waiter->unlock();
  return TRUE;
}

static gboolean lf_view_request_unlock_stop(GstBaseSrc* src) {
  LF_VIEW_REQUEST(src)->waiter->unlock_stop();
  return TRUE;
}

// Inverse depth of a focal plane along the camera-plane normal (0: infinity
// or parallel to the normal).
static double inverse_depth_of_UNUSED(const lf::Rig& rig, const lf::FocalPlane& p) {
  if (p.at_infinity()) return 0.0;
  const lf::CameraPlane& P = rig.plane();
  const double nn = p.n.dot(P.normal), off = p.n.dot(P.origin) + p.d;
  if (nn == 0 || off == 0) return 0.0;
  return std::max(0.0, -nn / off);
}

static void handle_navigation(LfViewRequest* self, GstEvent* event) {
  State* st = self->state;
  if (!st) return;
  const lf::Rig& rig = *st->rig;
  const double step = rig.typical_spacing();
  const lf::CameraPlane& P = rig.plane();
  double x = 0, y = 0, dx = 0, dy = 0;
  gint button = 0;
  const gchar* key = nullptr;
  g_mutex_lock(&self->lock);
  // Every camera branch forwards the same event upstream: apply it once.
  const guint32 seq = gst_event_get_seqnum(event);
  if (seq == st->last_seqnum) {
    g_mutex_unlock(&self->lock);
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
  g_mutex_unlock(&self->lock);
}

static gboolean lf_view_request_event(GstBaseSrc* src, GstEvent* event) {
  if (GST_EVENT_TYPE(event) == GST_EVENT_NAVIGATION) {
    handle_navigation(LF_VIEW_REQUEST(src), event);
    return TRUE;
  }
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
  State* st = self->state;
  const GstClockTime period = gst_util_uint64_scale_int(GST_SECOND, self->fps_d, self->fps_n);
  if (self->live)  // a viewer joining late starts at the current tick
    st->sequence = lfgst::first_current_tick(GST_ELEMENT(src), st->sequence, period, 0);
  const guint64 k = st->sequence;
  const GstClockTime pts = k * period;
  // Live: emit at running time pts on the pipeline clock.
  if (self->live && !self->waiter->wait_until(GST_ELEMENT(src), pts)) return GST_FLOW_FLUSHING;
  lf::ViewRequest req;
  req.viewer_id = self->viewer_id;
  req.sequence = k;
  try {
    const lf::Rig& rig = *st->rig;
    g_mutex_lock(&self->lock);
    const cv::Vec3d offset = st->offset;
    const bool q_active = st->q_active;
    const double q = st->q;
    g_mutex_unlock(&self->lock);
    req.view = st->views[k % st->views.size()];
    if (offset != cv::Vec3d(0, 0, 0)) {
      if (st->fixed_between_cameras)
        req.view = lf::view_between_cameras(rig, req.view.position + offset, req.view.width,
                                            req.view.height);
      else
        req.view.position += offset;
    }
    req.focal_plane = q_active ? lf::plane_at_inverse_depth(rig, q) : st->plane;
    if (self->stereo_baseline > 0) {
      // Left and right eyes along the view's x axis (viewer ids v, v + 1).
      const cv::Vec3d x(req.view.R(0, 0), req.view.R(0, 1), req.view.R(0, 2));
      lf::ViewRequest right = req;
      right.viewer_id = self->viewer_id + 1;
      right.view.position += x * (0.5 * self->stereo_baseline);
      req.view.position -= x * (0.5 * self->stereo_baseline);
      // One tick = one buffer list (num-buffers counts ticks).
      GstBufferList* list = gst_buffer_list_new_sized(2);
      gst_buffer_list_add(list, request_buffer(src, req, pts, period));
      gst_buffer_list_add(list, request_buffer(src, right, pts, period));
      gst_base_src_submit_buffer_list(src, list);
      *out = nullptr;
    } else {
      *out = request_buffer(src, req, pts, period);
    }
  } catch (const std::exception& e) {
    GST_ELEMENT_ERROR(self, LIBRARY, FAILED, ("Cannot build view request %" G_GUINT64_FORMAT, k),
                      ("%s", e.what()));
    return GST_FLOW_ERROR;
  }
  st->sequence++;
  return GST_FLOW_OK;
}

static gboolean lf_view_request_query(GstBaseSrc* src, GstQuery* q) {
  LfViewRequest* self = LF_VIEW_REQUEST(src);
  if (GST_QUERY_TYPE(q) == GST_QUERY_LATENCY && self->live) {
    gst_query_set_latency(q, TRUE, 0, GST_CLOCK_TIME_NONE);
    return TRUE;
  }
  return GST_BASE_SRC_CLASS(lf_view_request_parent_class)->query(src, q);
}

static void lf_view_request_finalize(GObject* obj) {
  LfViewRequest* self = LF_VIEW_REQUEST(obj);
  for (gchar* s : {self->rig, self->position, self->look_at, self->focal_plane, self->path})
    g_free(s);
  delete self->state;
  g_mutex_clear(&self->lock);
  delete self->waiter;
  G_OBJECT_CLASS(lf_view_request_parent_class)->finalize(obj);
}

static void lf_view_request_init(LfViewRequest* self) {
  self->width = 640;
  self->height = 480;
  self->focal_plane = g_strdup("infinity");
  self->path_frames = 120;
  self->fps_n = 30;
  self->fps_d = 1;
  g_mutex_init(&self->lock);
  self->waiter = new lfgst::ClockWaiter();
  gst_base_src_set_format(GST_BASE_SRC(self), GST_FORMAT_TIME);
}

static void lf_view_request_class_init(LfViewRequestClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  GstBaseSrcClass* bc = GST_BASE_SRC_CLASS(klass);
  oc->set_property = lf_view_request_set_property;
  oc->get_property = lf_view_request_get_property;
  oc->finalize = lf_view_request_finalize;
  const auto rw = static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
                                           GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(
      oc, PROP_RIG,
      g_param_spec_string("rig", "Rig", "Rig file (.json) or dataset folder (lf-render --input)",
                          nullptr, rw));
  g_object_class_install_property(
      oc, PROP_VIEWER_ID,
      g_param_spec_uint("viewer-id", "Viewer id", "Tag of this viewer's requests and output", 0,
                        G_MAXUINT32, 0, rw));
  g_object_class_install_property(
      oc, PROP_WIDTH,
      g_param_spec_int("width", "Width", "Output width, pixels", 2, 16384, 640, rw));
  g_object_class_install_property(
      oc, PROP_HEIGHT,
      g_param_spec_int("height", "Height", "Output height, pixels", 2, 16384, 480, rw));
  g_object_class_install_property(
      oc, PROP_POSITION,
      g_param_spec_string("position", "Position",
                          "Eye 'x,y,z' in rig units (empty: centre of the camera plane)", nullptr,
                          rw));
  g_object_class_install_property(
      oc, PROP_LOOK_AT,
      g_param_spec_string("look-at", "Look at",
                          "Target 'x,y,z' in rig units (empty: look like the rig's cameras, "
                          "with intrinsics interpolated from the surrounding ones)",
                          nullptr, rw));
  g_object_class_install_property(
      oc, PROP_VFOV,
      g_param_spec_double(
          "vfov", "Vertical FOV",
          "Vertical field of view, degrees (0: from the cameras, or 50 with look-at)", 0, 179.9, 0,
          rw));
  g_object_class_install_property(
      oc, PROP_FOCAL_PLANE,
      g_param_spec_string("focal-plane", "Focal plane",
                          "infinity | depth:Z (rig units from the camera plane) | param:A "
                          "(light-slab focal parameter, pixels of shift per unit) | "
                          "plane:nx,ny,nz,d",
                          "infinity", rw));
  g_object_class_install_property(
      oc, PROP_PATH,
      g_param_spec_string("path", "Camera path",
                          "Keyframed camera path (JSON, see README); overrides position", nullptr,
                          rw));
  g_object_class_install_property(
      oc, PROP_ORBIT,
      g_param_spec_double("orbit", "Orbit",
                          "Circular path on the camera plane, radius as a fraction of the "
                          "array's half extent (0: off)",
                          0, 10, 0, rw));
  g_object_class_install_property(
      oc, PROP_DOLLY,
      g_param_spec_double(
          "dolly", "Dolly",
          "With orbit: amplitude of motion along the camera-plane normal, rig units", -1e12, 1e12,
          0, rw));
  g_object_class_install_property(
      oc, PROP_PATH_FRAMES,
      g_param_spec_int("path-frames", "Path frames", "Requests per pass over the path/orbit", 1,
                       1000000, 120, rw));
  g_object_class_install_property(
      oc, PROP_FRAMERATE,
      gst_param_spec_fraction("framerate", "Frame rate", "Requests per second", 1, 1000, 1000, 1,
                              30, 1, rw));
  g_object_class_install_property(
      oc, PROP_IS_LIVE,
      g_param_spec_boolean("is-live", "Live", "Emit requests in real time on the pipeline clock",
                           FALSE, rw));
  g_object_class_install_property(
      oc, PROP_STEREO_BASELINE,
      g_param_spec_double("stereo-baseline", "Stereo baseline",
                          "Eye separation in rig units; > 0 emits a left (viewer-id) and a right "
                          "(viewer-id + 1) request per tick, for lfcompositor stereo=true",
                          0, 1e12, 0, rw));
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
  bc->create = lf_view_request_create;
  bc->unlock = lf_view_request_unlock;
  bc->unlock_stop = lf_view_request_unlock_stop;
  bc->query = lf_view_request_query;
  bc->event = lf_view_request_event;
  GST_DEBUG_CATEGORY_INIT(lf_view_request_debug, "lfviewrequest", 0, "light field view requests");
}

gboolean lf_view_request_register(GstPlugin* plugin) {
  return gst_element_register(plugin, "lfviewrequest", GST_RANK_NONE, LF_TYPE_VIEW_REQUEST);
}
