// lfcamsrc: one camera of a rig as a video source. Mode "dataset": the
// camera's still image from the rig (dataset folder or rig file) repeated as
// video. Frames are captured on a schedule aligned to the pipeline clock:
// running time k * period + phase (Yang et al. 2002, 4.4.4), so all cameras
// that share a clock capture within one frame of each other. Buffer PTS is
// the capture time (running time); OFFSET is the frame number.
#include <gst/app/gstappsink.h>
#include <gst/base/gstpushsrc.h>
#include <gst/video/video.h>

#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lf/synthetic.h"
#include "lfcommon.h"

GST_DEBUG_CATEGORY_STATIC(lf_cam_src_debug);
#define GST_CAT_DEFAULT lf_cam_src_debug

G_BEGIN_DECLS
#define LF_TYPE_CAM_SRC (lf_cam_src_get_type())
G_DECLARE_FINAL_TYPE(LfCamSrc, lf_cam_src, LF, CAM_SRC, GstPushSrc)
G_END_DECLS

namespace {
struct State {
  std::shared_ptr<const lf::Rig> rig;
  int index = -1;
  cv::Mat rgba;  // the still, RGBA (dataset mode)
  bool synthetic = false;
  lf::SyntheticScene scene;
  guint64 frame = 0;
  // file / v4l2 modes: an internal decoding pipeline ending in an appsink.
  GstElement* decoder = nullptr;
  GstElement* appsink = nullptr;
  GstBuffer* last = nullptr;  // newest decoded frame (not the sample: appsink reuses those)
  ~State() {
    if (last) gst_buffer_unref(last);
    if (decoder) {
      gst_element_set_state(decoder, GST_STATE_NULL);
      gst_object_unref(appsink);
      gst_object_unref(decoder);
    }
  }
};
}  // namespace

struct _LfCamSrc {
  GstPushSrc parent;
  gchar* rig;
  gint camera_id, row, col;
  gint fps_n, fps_d;
  guint64 phase;
  gboolean live;
  gint mode;
  gchar* location;
  gchar* device;
  gboolean loop;
  lfgst::ClockWaiter* waiter;
  State* state;
};

enum {
  PROP_0,
  PROP_RIG,
  PROP_CAMERA_ID,
  PROP_ROW,
  PROP_COL,
  PROP_FRAMERATE,
  PROP_PHASE,
  PROP_IS_LIVE,
  PROP_MODE,
  PROP_LOCATION,
  PROP_DEVICE,
  PROP_LOOP
};

G_DEFINE_TYPE(LfCamSrc, lf_cam_src, GST_TYPE_PUSH_SRC)

#define LF_TYPE_CAM_SRC_MODE (lf_cam_src_mode_get_type())
static GType lf_cam_src_mode_get_type() {
  static GType type = 0;
  static const GEnumValue values[] = {
      {0, "The camera's image from the rig (dataset), repeated as video", "dataset"},
      {1,
       "Synthetic dynamic scene rendered from the camera's calibration: a textured disc "
       "moving at a known depth over a textured background plane (lf::SyntheticScene)",
       "synthetic"},
      {2,
       "A video file or an image sequence (location; GStreamer's decoders), scaled to the "
       "rig's image size",
       "file"},
      {3, "A V4L2 capture device (device; through v4l2src), scaled to the rig's image size",
       "v4l2"},
      {0, nullptr, nullptr}};
  if (g_once_init_enter(&type))
    g_once_init_leave(&type, g_enum_register_static("LfCamSrcMode", values));
  return type;
}

static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE(
    "src", GST_PAD_SRC, GST_PAD_ALWAYS,
    GST_STATIC_CAPS("video/x-raw, format = (string) RGBA, width = (int) [ 2, 65535 ], "
                    "height = (int) [ 2, 65535 ], framerate = (fraction) [ 1/1, 1000/1 ]"));

static void lf_cam_src_set_property(GObject* obj, guint id, const GValue* v, GParamSpec* ps) {
  LfCamSrc* self = LF_CAM_SRC(obj);
  GST_OBJECT_LOCK(self);
  switch (id) {
    case PROP_RIG:
      g_free(self->rig);
      self->rig = g_value_dup_string(v);
      break;
    case PROP_CAMERA_ID:
      self->camera_id = g_value_get_int(v);
      break;
    case PROP_ROW:
      self->row = g_value_get_int(v);
      break;
    case PROP_COL:
      self->col = g_value_get_int(v);
      break;
    case PROP_FRAMERATE:
      self->fps_n = gst_value_get_fraction_numerator(v);
      self->fps_d = gst_value_get_fraction_denominator(v);
      break;
    case PROP_PHASE:
      self->phase = g_value_get_uint64(v);
      break;
    case PROP_IS_LIVE:
      self->live = g_value_get_boolean(v);
      break;
    case PROP_MODE:
      self->mode = g_value_get_enum(v);
      break;
    case PROP_LOCATION:
      g_free(self->location);
      self->location = g_value_dup_string(v);
      break;
    case PROP_DEVICE:
      g_free(self->device);
      self->device = g_value_dup_string(v);
      break;
    case PROP_LOOP:
      self->loop = g_value_get_boolean(v);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, ps);
  }
  GST_OBJECT_UNLOCK(self);
  // Must be known before READY->PAUSED (live sources do not preroll);
  // set_live takes the object lock itself.
  if (id == PROP_IS_LIVE) gst_base_src_set_live(GST_BASE_SRC(self), g_value_get_boolean(v));
}

static void lf_cam_src_get_property(GObject* obj, guint id, GValue* v, GParamSpec* ps) {
  LfCamSrc* self = LF_CAM_SRC(obj);
  GST_OBJECT_LOCK(self);
  switch (id) {
    case PROP_RIG:
      g_value_set_string(v, self->rig);
      break;
    case PROP_CAMERA_ID:
      g_value_set_int(v, self->camera_id);
      break;
    case PROP_ROW:
      g_value_set_int(v, self->row);
      break;
    case PROP_COL:
      g_value_set_int(v, self->col);
      break;
    case PROP_FRAMERATE:
      gst_value_set_fraction(v, self->fps_n, self->fps_d);
      break;
    case PROP_PHASE:
      g_value_set_uint64(v, self->phase);
      break;
    case PROP_IS_LIVE:
      g_value_set_boolean(v, self->live);
      break;
    case PROP_MODE:
      g_value_set_enum(v, self->mode);
      break;
    case PROP_LOCATION:
      g_value_set_string(v, self->location);
      break;
    case PROP_DEVICE:
      g_value_set_string(v, self->device);
      break;
    case PROP_LOOP:
      g_value_set_boolean(v, self->loop);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, ps);
  }
  GST_OBJECT_UNLOCK(self);
}

static gboolean lf_cam_src_start(GstBaseSrc* src) {
  LfCamSrc* self = LF_CAM_SRC(src);
  if (!self->rig || !*self->rig) {
    GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("No rig given"),
                      ("set the 'rig' property to a rig file or dataset folder"));
    return FALSE;
  }
  auto* st = new State();
  try {
    st->rig = lfgst::load_rig_cached(self->rig);
    const lf::Rig& rig = *st->rig;
    if (self->camera_id >= 0) {
      st->index = rig.index_of(self->camera_id);
      if (st->index < 0)
        throw std::invalid_argument("camera-id " + std::to_string(self->camera_id) +
                                    " is not in the rig");
    } else if (self->row >= 0 && self->col >= 0) {
      if (rig.grid.empty() || self->row >= rig.grid.rows || self->col >= rig.grid.cols ||
          rig.grid.at(self->row, self->col) < 0)
        throw std::invalid_argument("no camera at grid row " + std::to_string(self->row) +
                                    ", column " + std::to_string(self->col));
      st->index = rig.grid.at(self->row, self->col);
    } else {
      throw std::invalid_argument("set camera-id, or row and col");
    }
    const lf::Camera& cam = rig.cameras[st->index];
    if (self->mode == 2 || self->mode == 3) {
      gchar* scaled = g_strdup_printf(
          "videoconvert ! videoscale ! video/x-raw,format=RGBA,width=%d,height=%d,"
          "pixel-aspect-ratio=1/1 ! appsink name=frames sync=false max-buffers=2 drop=%s",
          cam.width, cam.height, self->mode == 3 ? "true" : "false");
      std::string desc;
      if (self->mode == 3) {
        desc = std::string("v4l2src device=") + (self->device ? self->device : "/dev/video0");
      } else {
        if (!self->location || !*self->location)
          throw std::invalid_argument(
              "mode=file needs 'location' (a file, or a printf "
              "pattern such as frames/%04d.png for an image sequence)");
        const std::string loc = self->location;
        if (loc.find('%') != std::string::npos) {
          desc = "multifilesrc location=\"" + loc + "\"" + (self->loop ? " loop=true" : "") +
                 " ! decodebin";
        } else {
          gchar* uri = gst_uri_is_valid(loc.c_str()) ? g_strdup(loc.c_str())
                                                     : gst_filename_to_uri(loc.c_str(), nullptr);
          if (!uri) throw std::invalid_argument("location '" + loc + "' is not a file or URI");
          desc = std::string("uridecodebin uri=\"") + uri + "\"";
          g_free(uri);
        }
      }
      desc += std::string(" ! ") + scaled;
      g_free(scaled);
      GError* err = nullptr;
      st->decoder = gst_parse_launch(desc.c_str(), &err);
      if (!st->decoder) {
        const std::string msg = err ? err->message : "cannot build the decoding pipeline";
        g_clear_error(&err);
        throw std::runtime_error(msg);
      }
      g_clear_error(&err);
      st->appsink = gst_bin_get_by_name(GST_BIN(st->decoder), "frames");
      if (gst_element_set_state(st->decoder, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE)
        throw std::runtime_error(
            "cannot open " + std::string(self->mode == 3 ? "device " : "") +
            (self->mode == 3 ? (self->device ? self->device : "/dev/video0") : self->location));
      st->rgba = cv::Mat(cam.height, cam.width, CV_8UC4);  // size for caps
    } else if (self->mode == 1) {
      st->synthetic = true;
      st->scene = lf::SyntheticScene::for_rig(rig);
      st->rgba = cv::Mat(cam.height, cam.width, CV_8UC4);  // size for caps
    } else {
      if (cam.image.empty())
        throw std::invalid_argument("camera " + std::to_string(cam.id) +
                                    " has no image file (use mode=synthetic)");
      cv::Mat bgr = cv::imread(cam.image, cv::IMREAD_COLOR);
      if (bgr.empty()) throw std::runtime_error("image " + cam.image + ": missing or unreadable");
      if (bgr.cols != cam.width || bgr.rows != cam.height)
        cv::resize(bgr, bgr, cv::Size(cam.width, cam.height), 0, 0, cv::INTER_AREA);
      cv::cvtColor(bgr, st->rgba, cv::COLOR_BGR2RGBA);
    }
  } catch (const std::exception& e) {
    delete st;
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("Cannot open the camera"), ("%s", e.what()));
    return FALSE;
  }
  delete self->state;
  self->state = st;
  return TRUE;
}

static gboolean lf_cam_src_stop(GstBaseSrc* src) {
  LfCamSrc* self = LF_CAM_SRC(src);
  delete self->state;
  self->state = nullptr;
  return TRUE;
}

static GstCaps* lf_cam_src_get_caps(GstBaseSrc* src, GstCaps* filter) {
  LfCamSrc* self = LF_CAM_SRC(src);
  GstCaps* caps;
  if (self->state) {
    caps = gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, "RGBA", "width", G_TYPE_INT,
                               self->state->rgba.cols, "height", G_TYPE_INT, self->state->rgba.rows,
                               "framerate", GST_TYPE_FRACTION, self->fps_n, self->fps_d, nullptr);
  } else {
    caps = gst_pad_get_pad_template_caps(GST_BASE_SRC_PAD(src));
  }
  if (filter) {
    GstCaps* t = gst_caps_intersect_full(filter, caps, GST_CAPS_INTERSECT_FIRST);
    gst_caps_unref(caps);
    caps = t;
  }
  return caps;
}

static gboolean lf_cam_src_unlock(GstBaseSrc* src) {
  LF_CAM_SRC(src)->waiter->unlock();
  return TRUE;
}

static gboolean lf_cam_src_unlock_stop(GstBaseSrc* src) {
  LF_CAM_SRC(src)->waiter->unlock_stop();
  return TRUE;
}

static void free_mat(gpointer p) {
  delete static_cast<cv::Mat*>(p);
}

static GstFlowReturn lf_cam_src_create(GstPushSrc* src, GstBuffer** out) {
  LfCamSrc* self = LF_CAM_SRC(src);
  State* st = self->state;
  const GstClockTime period = gst_util_uint64_scale_int(GST_SECOND, self->fps_d, self->fps_n);
  if (self->live)
    st->frame = lfgst::first_current_tick(GST_ELEMENT(src), st->frame, period, self->phase);
  const GstClockTime pts = st->frame * period + self->phase;
  // Capture time, frame number and the capture meta on every frame.
  auto stamp = [&](GstBuffer* buf) {
    GST_BUFFER_PTS(buf) = pts;
    GST_BUFFER_DTS(buf) = pts;
    GST_BUFFER_DURATION(buf) = period;
    GST_BUFFER_OFFSET(buf) = st->frame++;
    lfgst::add_capture_meta(buf, st->rig->cameras[st->index].id, pts);
    lfgst::trace(GST_ELEMENT(src), "capture", 0, GST_BUFFER_OFFSET(buf),
                 st->rig->cameras[st->index].id, static_cast<gint64>(pts));
    return buf;
  };
  // Live: emit at running time pts on the pipeline clock.
  if (self->live && !self->waiter->wait_until(GST_ELEMENT(src), pts)) return GST_FLOW_FLUSHING;
  if (st->decoder) {
    // File: the next decoded frame (looping a plain file on EOS if asked);
    // V4L2 (live): the newest frame at the capture instant.
    GstAppSink* sink = GST_APP_SINK(st->appsink);
    GstSample* s = nullptr;
    if (self->mode == 3) {
      while (GstSample* n = gst_app_sink_try_pull_sample(sink, 0)) {
        if (s) gst_sample_unref(s);
        s = n;
      }
      if (!s && !st->last) s = gst_app_sink_try_pull_sample(sink, 5 * GST_SECOND);
    } else {
      s = gst_app_sink_try_pull_sample(sink, 30 * GST_SECOND);
      if (!s && gst_app_sink_is_eos(sink) && self->loop &&
          gst_element_seek_simple(st->decoder, GST_FORMAT_TIME, GST_SEEK_FLAG_FLUSH, 0))
        s = gst_app_sink_try_pull_sample(sink, 30 * GST_SECOND);
      if (!s) {
        if (gst_app_sink_is_eos(sink)) return GST_FLOW_EOS;
      }
    }
    if (s) {
      gst_buffer_replace(&st->last, gst_sample_get_buffer(s));
      gst_sample_unref(s);
    }
    if (!st->last) {
      GST_ELEMENT_ERROR(self, RESOURCE, READ, ("No frame from the camera input"),
                        ("decoding pipeline delivered nothing"));
      return GST_FLOW_ERROR;
    }
    *out = stamp(gst_buffer_copy_deep(st->last));
    return GST_FLOW_OK;
  }
  // Dataset: zero-copy, the buffer shares the still (read-only). Synthetic:
  // the scene at the capture time.
  auto* ref = new cv::Mat(st->synthetic ? st->scene.render(st->rig->cameras[st->index], pts / 1e9)
                                        : st->rgba);
  GstBuffer* buf = gst_buffer_new_wrapped_full(GST_MEMORY_FLAG_READONLY, ref->data,
                                               ref->total() * ref->elemSize(), 0,
                                               ref->total() * ref->elemSize(), ref, free_mat);
  *out = stamp(buf);
  return GST_FLOW_OK;
}

static gboolean lf_cam_src_query(GstBaseSrc* src, GstQuery* q) {
  LfCamSrc* self = LF_CAM_SRC(src);
  if (GST_QUERY_TYPE(q) == GST_QUERY_LATENCY && self->live) {
    gst_query_set_latency(q, TRUE, 0, GST_CLOCK_TIME_NONE);
    return TRUE;
  }
  return GST_BASE_SRC_CLASS(lf_cam_src_parent_class)->query(src, q);
}

static void lf_cam_src_finalize(GObject* obj) {
  LfCamSrc* self = LF_CAM_SRC(obj);
  g_free(self->rig);
  g_free(self->location);
  g_free(self->device);
  delete self->state;
  delete self->waiter;
  G_OBJECT_CLASS(lf_cam_src_parent_class)->finalize(obj);
}

static void lf_cam_src_init(LfCamSrc* self) {
  self->camera_id = -1;
  self->row = self->col = -1;
  self->device = g_strdup("/dev/video0");
  self->fps_n = 30;
  self->fps_d = 1;
  self->waiter = new lfgst::ClockWaiter();
  gst_base_src_set_format(GST_BASE_SRC(self), GST_FORMAT_TIME);
}

static void lf_cam_src_class_init(LfCamSrcClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  GstBaseSrcClass* bc = GST_BASE_SRC_CLASS(klass);
  GstPushSrcClass* pc = GST_PUSH_SRC_CLASS(klass);
  oc->set_property = lf_cam_src_set_property;
  oc->get_property = lf_cam_src_get_property;
  oc->finalize = lf_cam_src_finalize;
  const auto rw = static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
                                           GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(
      oc, PROP_RIG,
      g_param_spec_string("rig", "Rig", "Rig file (.json) or dataset folder", nullptr, rw));
  g_object_class_install_property(
      oc, PROP_CAMERA_ID,
      g_param_spec_int("camera-id", "Camera id", "Camera id in the rig (-1: use row and col)", -1,
                       G_MAXINT, -1, rw));
  g_object_class_install_property(
      oc, PROP_ROW,
      g_param_spec_int("row", "Row", "Grid row of the camera (-1: unset)", -1, 65535, -1, rw));
  g_object_class_install_property(
      oc, PROP_COL,
      g_param_spec_int("col", "Column", "Grid column of the camera (-1: unset)", -1, 65535, -1,
                       rw));
  g_object_class_install_property(
      oc, PROP_FRAMERATE,
      gst_param_spec_fraction("framerate", "Frame rate", "Capture rate, frames per second", 1, 1,
                              1000, 1, 30, 1, rw));
  g_object_class_install_property(
      oc, PROP_PHASE,
      g_param_spec_uint64("phase", "Phase",
                          "Capture schedule offset, ns: frame k is captured at running time "
                          "k * period + phase",
                          0, G_MAXUINT64, 0, rw));
  g_object_class_install_property(
      oc, PROP_IS_LIVE,
      g_param_spec_boolean("is-live", "Live",
                           "Capture in real time on the pipeline clock's schedule", FALSE, rw));
  g_object_class_install_property(
      oc, PROP_MODE,
      g_param_spec_enum("mode", "Mode", "Where frames come from", LF_TYPE_CAM_SRC_MODE, 0, rw));
  g_object_class_install_property(
      oc, PROP_LOCATION,
      g_param_spec_string("location", "Location",
                          "mode=file: a video file or URI, or a printf pattern of an image "
                          "sequence (frames/%04d.png)",
                          nullptr, rw));
  g_object_class_install_property(
      oc, PROP_DEVICE,
      g_param_spec_string("device", "Device", "mode=v4l2: the capture device", "/dev/video0", rw));
  g_object_class_install_property(
      oc, PROP_LOOP,
      g_param_spec_boolean("loop", "Loop", "mode=file: start again at the end", FALSE, rw));
  gst_element_class_add_static_pad_template(ec, &src_template);
  gst_element_class_set_static_metadata(
      ec, "Light field camera source", "Source/Video",
      "One camera of a light field rig (dataset stills as video, or a synthetic dynamic scene), "
      "captured on a clock-aligned schedule",
      "lightfield-gst");
  bc->start = lf_cam_src_start;
  bc->stop = lf_cam_src_stop;
  bc->get_caps = lf_cam_src_get_caps;
  bc->unlock = lf_cam_src_unlock;
  bc->unlock_stop = lf_cam_src_unlock_stop;
  bc->query = lf_cam_src_query;
  pc->create = lf_cam_src_create;
  GST_DEBUG_CATEGORY_INIT(lf_cam_src_debug, "lfcamsrc", 0, "light field camera source");
}

gboolean lf_cam_src_register(GstPlugin* plugin) {
  return gst_element_register(plugin, "lfcamsrc", GST_RANK_NONE, LF_TYPE_CAM_SRC);
}
