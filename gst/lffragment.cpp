// lffragment: the paper's "random access camera" (Yang et al. 2002, 4.2).
// Camera frames arrive on "sink", view requests on "request"; for every
// request the newest frame is warped into this camera's fragment of the
// requested view (lib/lf/plan.h, lib/lf/fragment.h) and pushed on "src",
// tagged in band (lib/lf/wire.h). Cameras that do not contribute send an
// explicitly empty fragment, so the compositor knows the request is complete.
#include <gst/video/video.h>

#include <memory>
#include <opencv2/imgproc.hpp>

#include "lf/composite.h"
#include "lf/fragment.h"
#include "lf/plan.h"
#include "lf/render.h"
#include "lf/wire.h"
#include "lfcommon.h"

GST_DEBUG_CATEGORY_STATIC(lf_fragment_debug);
#define GST_CAT_DEFAULT lf_fragment_debug

G_BEGIN_DECLS
#define LF_TYPE_FRAGMENT (lf_fragment_get_type())
G_DECLARE_FINAL_TYPE(LfFragment, lf_fragment, LF, FRAGMENT, GstElement)
G_END_DECLS

#define LF_TYPE_FRAGMENT_ENCODING (lf_fragment_encoding_get_type())
static GType lf_fragment_encoding_get_type() {
  static GType type = 0;
  static const GEnumValue values[] = {{0, "Raw premultiplied RGBA row spans", "raw"},
                                      {1, "JPEG (4-component, TurboJPEG)", "jpeg"},
                                      {0, nullptr, nullptr}};
  if (g_once_init_enter(&type))
    g_once_init_leave(&type, g_enum_register_static("LfFragmentEncoding", values));
  return type;
}

namespace {
struct State {
  std::shared_ptr<const lf::Rig> rig;
  int index = -1;
  // Colour-corrected copy of the newest frame (only when the camera has a
  // correction), made once per frame, not once per request.
  GstBuffer* corrected_of = nullptr;  // the frame it was made from (not owned, compared only)
  cv::Mat corrected;
};
}  // namespace

struct _LfFragment {
  GstElement parent;
  GstPad* sinkpad;
  GstPad* requestpad;
  GstPad* srcpad;
  gchar* rig;
  gint camera_id;
  gint encoding;
  gint quality;
  GMutex lock;
  GCond cond;
  GstBuffer* frame;  // newest camera frame
  GstVideoInfo vinfo;
  gboolean have_vinfo;
  gboolean video_eos;
  gboolean flushing;
  State* state;
};

enum { PROP_0, PROP_RIG, PROP_CAMERA_ID, PROP_ENCODING, PROP_QUALITY };

G_DEFINE_TYPE(LfFragment, lf_fragment, GST_TYPE_ELEMENT)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink", GST_PAD_SINK, GST_PAD_ALWAYS,
    GST_STATIC_CAPS("video/x-raw, format = (string) { RGBA, RGBx }, width = (int) [ 2, 65535 ], "
                    "height = (int) [ 2, 65535 ], framerate = (fraction) [ 0/1, MAX ]"));
static GstStaticPadTemplate request_template = GST_STATIC_PAD_TEMPLATE(
    "request", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_REQUEST_CAPS));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_FRAGMENT_CAPS));

static void lf_fragment_set_property(GObject* obj, guint id, const GValue* v, GParamSpec* ps) {
  LfFragment* self = LF_FRAGMENT(obj);
  GST_OBJECT_LOCK(self);
  switch (id) {
    case PROP_RIG:
      g_free(self->rig);
      self->rig = g_value_dup_string(v);
      break;
    case PROP_CAMERA_ID:
      self->camera_id = g_value_get_int(v);
      break;
    case PROP_ENCODING:
      self->encoding = g_value_get_enum(v);
      break;
    case PROP_QUALITY:
      self->quality = g_value_get_int(v);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, ps);
  }
  GST_OBJECT_UNLOCK(self);
}

static void lf_fragment_get_property(GObject* obj, guint id, GValue* v, GParamSpec* ps) {
  LfFragment* self = LF_FRAGMENT(obj);
  GST_OBJECT_LOCK(self);
  switch (id) {
    case PROP_RIG:
      g_value_set_string(v, self->rig);
      break;
    case PROP_CAMERA_ID:
      g_value_set_int(v, self->camera_id);
      break;
    case PROP_ENCODING:
      g_value_set_enum(v, self->encoding);
      break;
    case PROP_QUALITY:
      g_value_set_int(v, self->quality);
      break;
    default:
      G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, ps);
  }
  GST_OBJECT_UNLOCK(self);
}

// ---- camera frames -------------------------------------------------------

static gboolean lf_fragment_sink_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  LfFragment* self = LF_FRAGMENT(parent);
  switch (GST_EVENT_TYPE(event)) {
    case GST_EVENT_CAPS: {
      GstCaps* caps;
      gst_event_parse_caps(event, &caps);
      GstVideoInfo info;
      if (!gst_video_info_from_caps(&info, caps)) {
        GST_ELEMENT_ERROR(self, STREAM, FORMAT, ("Invalid camera caps"), (nullptr));
        gst_event_unref(event);
        return FALSE;
      }
      if (self->state) {
        const lf::Camera& cam = self->state->rig->cameras[self->state->index];
        if (GST_VIDEO_INFO_WIDTH(&info) != cam.width ||
            GST_VIDEO_INFO_HEIGHT(&info) != cam.height) {
          GST_ELEMENT_ERROR(
              self, STREAM, FORMAT, ("Camera frame size does not match the rig"),
              ("camera %d: frames are %dx%d, the rig says %dx%d", cam.id,
               GST_VIDEO_INFO_WIDTH(&info), GST_VIDEO_INFO_HEIGHT(&info), cam.width, cam.height));
          gst_event_unref(event);
          return FALSE;
        }
      }
      g_mutex_lock(&self->lock);
      self->vinfo = info;
      self->have_vinfo = TRUE;
      g_mutex_unlock(&self->lock);
      gst_event_unref(event);
      return TRUE;
    }
    case GST_EVENT_EOS:
      // The camera stream ending does not end the fragment stream: the
      // newest frame stays in use (stills, or a camera that stopped).
      g_mutex_lock(&self->lock);
      self->video_eos = TRUE;
      g_cond_broadcast(&self->cond);
      g_mutex_unlock(&self->lock);
      gst_event_unref(event);
      return TRUE;
    case GST_EVENT_FLUSH_START:
      g_mutex_lock(&self->lock);
      self->flushing = TRUE;
      g_cond_broadcast(&self->cond);
      g_mutex_unlock(&self->lock);
      gst_event_unref(event);
      return TRUE;
    case GST_EVENT_FLUSH_STOP:
      g_mutex_lock(&self->lock);
      self->flushing = FALSE;
      self->video_eos = FALSE;
      g_mutex_unlock(&self->lock);
      gst_event_unref(event);
      return TRUE;
    default:
      gst_event_unref(event);
      return TRUE;
  }
  (void)pad;
}

static GstFlowReturn lf_fragment_sink_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  LfFragment* self = LF_FRAGMENT(parent);
  g_mutex_lock(&self->lock);
  if (self->flushing) {
    g_mutex_unlock(&self->lock);
    gst_buffer_unref(buf);
    return GST_FLOW_FLUSHING;
  }
  gst_buffer_replace(&self->frame, buf);
  g_cond_broadcast(&self->cond);
  g_mutex_unlock(&self->lock);
  gst_buffer_unref(buf);
  return GST_FLOW_OK;
}

// ---- view requests -------------------------------------------------------

static gboolean lf_fragment_request_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  LfFragment* self = LF_FRAGMENT(parent);
  switch (GST_EVENT_TYPE(event)) {
    case GST_EVENT_CAPS: {
      gst_event_unref(event);
      GstCaps* caps = gst_caps_new_simple("application/x-lf-fragment", "encoding", G_TYPE_STRING,
                                          self->encoding == 1 ? "jpeg" : "raw", nullptr);
      const gboolean ok = gst_pad_push_event(self->srcpad, gst_event_new_caps(caps));
      gst_caps_unref(caps);
      return ok;
    }
    case GST_EVENT_FLUSH_START:
      g_mutex_lock(&self->lock);
      self->flushing = TRUE;
      g_cond_broadcast(&self->cond);
      g_mutex_unlock(&self->lock);
      return gst_pad_push_event(self->srcpad, event);
    case GST_EVENT_FLUSH_STOP:
      g_mutex_lock(&self->lock);
      self->flushing = FALSE;
      g_mutex_unlock(&self->lock);
      return gst_pad_push_event(self->srcpad, event);
    default:
      return gst_pad_event_default(pad, parent, event);
  }
}

static GstFlowReturn lf_fragment_request_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  LfFragment* self = LF_FRAGMENT(parent);
  State* st = self->state;
  lf::ViewRequest req;
  {
    GstMapInfo map;
    if (!gst_buffer_map(buf, &map, GST_MAP_READ)) {
      gst_buffer_unref(buf);
      return GST_FLOW_ERROR;
    }
    try {
      req = lf::parse_request(map.data, map.size);
    } catch (const std::exception& e) {
      gst_buffer_unmap(buf, &map);
      GST_ELEMENT_WARNING(self, STREAM, DECODE, ("Dropping a malformed view request"),
                          ("%s", e.what()));
      gst_buffer_unref(buf);
      return GST_FLOW_OK;
    }
    gst_buffer_unmap(buf, &map);
  }
  const gint cam_id = st->rig->cameras[st->index].id;
  lfgst::trace(GST_ELEMENT(self), "request-in", req.viewer_id, req.sequence, cam_id);
  // Wait for a camera frame.
  g_mutex_lock(&self->lock);
  while (!self->frame && !self->flushing && !self->video_eos) g_cond_wait(&self->cond, &self->lock);
  if (self->flushing) {
    g_mutex_unlock(&self->lock);
    gst_buffer_unref(buf);
    return GST_FLOW_FLUSHING;
  }
  GstBuffer* frame = self->frame ? gst_buffer_ref(self->frame) : nullptr;
  const GstVideoInfo info = self->vinfo;
  const gboolean have_info = self->have_vinfo;
  g_mutex_unlock(&self->lock);
  if (!frame || !have_info) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("No camera frame"),
                      ("the camera stream ended before delivering a frame"));
    if (frame) gst_buffer_unref(frame);
    gst_buffer_unref(buf);
    return GST_FLOW_ERROR;
  }
  GstVideoFrame vf;
  if (!gst_video_frame_map(&vf, const_cast<GstVideoInfo*>(&info), frame, GST_MAP_READ)) {
    gst_buffer_unref(frame);
    gst_buffer_unref(buf);
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Cannot map the camera frame"), (nullptr));
    return GST_FLOW_ERROR;
  }
  std::vector<uint8_t> bytes;
  try {
    const lf::Rig& rig = *st->rig;
    const cv::Mat image(GST_VIDEO_FRAME_HEIGHT(&vf), GST_VIDEO_FRAME_WIDTH(&vf), CV_8UC4,
                        GST_VIDEO_FRAME_PLANE_DATA(&vf, 0), GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 0));
    cv::Mat rgba = image;
    const lf::Camera& cam = rig.cameras[st->index];
    const bool rgbx = GST_VIDEO_INFO_FORMAT(&info) == GST_VIDEO_FORMAT_RGBx;
    if (rgbx || cam.has_colour_correction()) {
      g_mutex_lock(&self->lock);
      if (st->corrected_of != frame || st->corrected.empty()) {
        cv::Mat out;
        if (cam.has_colour_correction()) {
          cv::Mat m(cam.colour), rgb;
          cv::cvtColor(image, rgb, cv::COLOR_RGBA2RGB);
          cv::transform(rgb, rgb, m);                  // saturating
          cv::cvtColor(rgb, out, cv::COLOR_RGB2RGBA);  // alpha 255
          if (!rgbx) {
            std::vector<cv::Mat> ch;
            cv::split(out, ch);
            cv::extractChannel(image, ch[3], 3);
            cv::merge(ch, out);
          }
        } else {
          cv::cvtColor(image, out, cv::COLOR_RGBA2RGB);  // x is undefined: alpha 255
          cv::cvtColor(out, out, cv::COLOR_RGB2RGBA);
        }
        st->corrected = out;
        st->corrected_of = frame;
      }
      rgba = st->corrected;
      g_mutex_unlock(&self->lock);
    }
    const lf::ViewGeometry g(rig, req, st->index);  // only this camera's homography
    lf::Fragment f;
    f.viewer_id = req.viewer_id;
    f.sequence = req.sequence;
    int meta_cam = -1;
    guint64 meta_time = 0;
    if (lfgst::read_capture_meta(frame, &meta_cam, &meta_time)) {
      if (meta_cam != rig.cameras[st->index].id)
        GST_WARNING_OBJECT(self, "frames come from camera %d, this is camera %d", meta_cam,
                           rig.cameras[st->index].id);
      f.capture_time_ns = static_cast<int64_t>(meta_time);
    } else {
      f.capture_time_ns =
          GST_BUFFER_PTS_IS_VALID(frame) ? static_cast<int64_t>(GST_BUFFER_PTS(frame)) : -1;
    }
    lf::render_fragment(lf::plan_fragment(g, st->index), rig.cameras[st->index], rgba, f);
    lfgst::trace(GST_ELEMENT(self), "warped", req.viewer_id, req.sequence, cam_id,
                 static_cast<gint64>(f.pixel_count()));
    bytes = lf::serialize_fragment(
        f, self->encoding == 1 ? lf::Encoding::kJpeg : lf::Encoding::kRaw, self->quality);
    lfgst::trace(GST_ELEMENT(self), "encoded", req.viewer_id, req.sequence, cam_id,
                 static_cast<gint64>(bytes.size()));
  } catch (const std::exception& e) {
    gst_video_frame_unmap(&vf);
    gst_buffer_unref(frame);
    gst_buffer_unref(buf);
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Fragment rendering failed"), ("%s", e.what()));
    return GST_FLOW_ERROR;
  }
  gst_video_frame_unmap(&vf);
  gst_buffer_unref(frame);
  GstBuffer* out = gst_buffer_new_memdup(bytes.data(), bytes.size());
  gst_buffer_copy_into(out, buf, GST_BUFFER_COPY_TIMESTAMPS, 0, -1);
  GST_BUFFER_OFFSET(out) = req.sequence;
  gst_buffer_unref(buf);
  return gst_pad_push(self->srcpad, out);
}

static GstStateChangeReturn lf_fragment_change_state(GstElement* el, GstStateChange t) {
  LfFragment* self = LF_FRAGMENT(el);
  if (t == GST_STATE_CHANGE_READY_TO_PAUSED) {
    if (!self->rig || !*self->rig) {
      GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("No rig given"),
                        ("set the 'rig' property to a rig file or dataset folder"));
      return GST_STATE_CHANGE_FAILURE;
    }
    auto* st = new State();
    try {
      st->rig = lfgst::load_rig_cached(self->rig);
      st->index = st->rig->index_of(self->camera_id);
      if (st->index < 0)
        throw std::invalid_argument("camera-id " + std::to_string(self->camera_id) +
                                    " is not in the rig");
    } catch (const std::exception& e) {
      delete st;
      GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("Cannot set up the camera"), ("%s", e.what()));
      return GST_STATE_CHANGE_FAILURE;
    }
    delete self->state;
    self->state = st;
  }
  if (t == GST_STATE_CHANGE_PAUSED_TO_READY) {
    g_mutex_lock(&self->lock);
    gst_buffer_replace(&self->frame, nullptr);
    self->video_eos = FALSE;
    self->have_vinfo = FALSE;
    g_mutex_unlock(&self->lock);
  }
  return GST_ELEMENT_CLASS(lf_fragment_parent_class)->change_state(el, t);
}

static void lf_fragment_finalize(GObject* obj) {
  LfFragment* self = LF_FRAGMENT(obj);
  g_free(self->rig);
  gst_buffer_replace(&self->frame, nullptr);
  delete self->state;
  g_mutex_clear(&self->lock);
  g_cond_clear(&self->cond);
  G_OBJECT_CLASS(lf_fragment_parent_class)->finalize(obj);
}

static void lf_fragment_init(LfFragment* self) {
  self->camera_id = 0;
  self->quality = 90;
  g_mutex_init(&self->lock);
  g_cond_init(&self->cond);
  self->sinkpad = gst_pad_new_from_static_template(&sink_template, "sink");
  gst_pad_set_chain_function(self->sinkpad, lf_fragment_sink_chain);
  gst_pad_set_event_function(self->sinkpad, lf_fragment_sink_event);
  gst_element_add_pad(GST_ELEMENT(self), self->sinkpad);
  self->requestpad = gst_pad_new_from_static_template(&request_template, "request");
  gst_pad_set_chain_function(self->requestpad, lf_fragment_request_chain);
  gst_pad_set_event_function(self->requestpad, lf_fragment_request_event);
  gst_element_add_pad(GST_ELEMENT(self), self->requestpad);
  self->srcpad = gst_pad_new_from_static_template(&src_template, "src");
  gst_pad_use_fixed_caps(self->srcpad);
  gst_element_add_pad(GST_ELEMENT(self), self->srcpad);
}

static void lf_fragment_class_init(LfFragmentClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  oc->set_property = lf_fragment_set_property;
  oc->get_property = lf_fragment_get_property;
  oc->finalize = lf_fragment_finalize;
  const auto rw = static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
                                           GST_PARAM_MUTABLE_READY);
  g_object_class_install_property(
      oc, PROP_RIG,
      g_param_spec_string("rig", "Rig", "Rig file (.json) or dataset folder", nullptr, rw));
  g_object_class_install_property(
      oc, PROP_CAMERA_ID,
      g_param_spec_int("camera-id", "Camera id", "This camera's id in the rig", 0, G_MAXINT, 0,
                       rw));
  g_object_class_install_property(
      oc, PROP_ENCODING,
      g_param_spec_enum("encoding", "Encoding", "Fragment payload encoding",
                        LF_TYPE_FRAGMENT_ENCODING, 0, rw));
  g_object_class_install_property(
      oc, PROP_QUALITY,
      g_param_spec_int("jpeg-quality", "JPEG quality", "JPEG quality (encoding=jpeg), 1..100", 1,
                       100, 90,
                       static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
                                                GST_PARAM_MUTABLE_PLAYING)));
  gst_element_class_add_static_pad_template(ec, &sink_template);
  gst_element_class_add_static_pad_template(ec, &request_template);
  gst_element_class_add_static_pad_template(ec, &src_template);
  gst_element_class_set_static_metadata(
      ec, "Light field fragment", "Filter/Video",
      "Random access camera: renders this camera's fragment of each requested view from its "
      "newest frame (Yang et al. 2002, 4.2)",
      "lightfield-gst");
  ec->change_state = lf_fragment_change_state;
  GST_DEBUG_CATEGORY_INIT(lf_fragment_debug, "lffragment", 0, "light field fragments");
}

gboolean lf_fragment_register(GstPlugin* plugin) {
  return gst_element_register(plugin, "lffragment", GST_RANK_NONE, LF_TYPE_FRAGMENT);
}
