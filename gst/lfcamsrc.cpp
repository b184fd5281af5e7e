/**
 * SECTION:element-lfcamsrc
 * @title: lfcamsrc
 *
 * One camera of a light field rig as a video source (`video/x-raw`, RGBA, the
 * rig's image size). `mode=dataset`: the camera's still image from the rig,
 * repeated (decoded from start on, beside the other cameras' stills: a
 * missing file fails the start, one that does not decode the first frame;
 * decoded stills are kept in `still-cache`, by default
 * $XDG_CACHE_HOME/lightfield-gst/stills, at most 1 GiB, so that a restart
 * reads them in milliseconds instead of decoding again: lib/lf/io/still_cache.h);
 * `mode=synthetic`: a dynamic scene with known depths ray-cast from
 * the camera's calibration (lib/lf/quality/synthetic.h); `mode=file`: a video file or
 * image sequence (`location`) through GStreamer's decoders; `mode=v4l2`: a
 * capture `device`. Frames are captured on a schedule aligned to the pipeline
 * clock: running time k * period + phase (Yang et al. 2002, 4.4.4), so all
 * cameras that share a clock capture within one frame of each other. Buffer
 * PTS is the capture time (running time); OFFSET is the frame number; every
 * frame carries an `LfCaptureMeta` (camera-id, capture-time).
 *
 * The camera is named like lffragment's: `camera-id`, or `row` and `col` of
 * the rig's grid.
 *
 * `noise` adds sensor noise to the dataset and synthetic modes' frames
 * (lf::with_sensor_noise: Gaussian, per channel, seeded by camera and frame
 * number, so a run is reproducible): what separates a real camera's video
 * from a still, and what costs a video codec its temporal prediction.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfcamsrc rig=rig.json row=2 col=3 mode=synthetic num-buffers=30 ! \
 *   videoconvert ! autovideosink
 * ]|
 */
#include <gst/base/gstpushsrc.h>
#include <gst/video/video.h>

#include <future>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>

#include "lf/io/image_io.h"
#include "lf/io/parse.h"
#include "lf/io/still_cache.h"
#include "lf/quality/synthetic.h"
#include "lfcamerainput.h"
#include "lfclock.h"
#include "lfguard.h"
#include "lfmeta.h"
#include "lfprops.h"
#include "lfrig.h"
#include "lftrace.h"

GST_DEBUG_CATEGORY_STATIC(lf_cam_src_debug);
#define GST_CAT_DEFAULT lf_cam_src_debug

G_BEGIN_DECLS
#define LF_TYPE_CAM_SRC (lf_cam_src_get_type())
G_DECLARE_FINAL_TYPE(LfCamSrc, lf_cam_src, LF, CAM_SRC, GstPushSrc)
G_END_DECLS

namespace {
enum class Mode { kDataset = 0, kSynthetic = 1, kFile = 2, kV4l2 = 3 };
}  // namespace

#define DEFAULT_FPS_N 30
#define DEFAULT_FPS_D 1
#define DEFAULT_PHASE 0
#define DEFAULT_IS_LIVE FALSE
#define DEFAULT_MODE Mode::kDataset
#define DEFAULT_DEVICE "/dev/video0"
#define DEFAULT_LOOP FALSE
#define DEFAULT_NOISE 0.0

// Decoded stills (mode=dataset) are kept in $XDG_CACHE_HOME/lightfield-gst/stills.
static std::string default_still_cache() {
  static const std::string dir = std::string(g_get_user_cache_dir()) + G_DIR_SEPARATOR_S
                                 "lightfield-gst" G_DIR_SEPARATOR_S "stills";
  return dir;
}

#define LF_TYPE_CAM_SRC_MODE (lf_cam_src_mode_get_type())
static GType lf_cam_src_mode_get_type() {
  static GType type = 0;
  static const GEnumValue values[] = {
      {static_cast<gint>(Mode::kDataset),
       "The camera's image from the rig (dataset), repeated as video", "dataset"},
      {static_cast<gint>(Mode::kSynthetic),
       "Synthetic dynamic scene rendered from the camera's calibration: a textured disc "
       "moving at a known depth over a textured background plane (lf::SyntheticScene)",
       "synthetic"},
      {static_cast<gint>(Mode::kFile),
       "A video file or an image sequence (location; GStreamer's decoders), scaled to the "
       "rig's image size",
       "file"},
      {static_cast<gint>(Mode::kV4l2),
       "A V4L2 capture device (device; through v4l2src), scaled to the rig's image size", "v4l2"},
      {0, nullptr, nullptr}};
  return lfgst::enum_type(&type, "LfCamSrcMode", values);
}

namespace {
struct Settings : lfgst::CameraAddress {
  std::string rig;
  lfgst::Fraction framerate{DEFAULT_FPS_N, DEFAULT_FPS_D};
  guint64 phase = DEFAULT_PHASE;
  bool live = DEFAULT_IS_LIVE;
  Mode mode = DEFAULT_MODE;
  std::string location;
  std::string device = DEFAULT_DEVICE;
  bool loop = DEFAULT_LOOP;
  double noise = DEFAULT_NOISE;  // sensor noise, standard deviation in 8-bit levels
  bool skip_bad_frames = false;  // file mode: a frame that does not decode is a warning
  std::string still_cache = default_still_cache();  // "" = off
};

// From start (READY->PAUSED) to stop (PAUSED->READY).
struct State {
  Settings s;  // snapshot taken at start
  std::shared_ptr<const lf::Rig> rig;
  int index = -1;
  cv::Mat rgba;  // the still, RGBA (dataset mode; until `still` is in, its size only)
  // Dataset mode: the still, decoded on a thread of its own from start on,
  // so that a host's cameras decode their images at once rather than one
  // after another as the bin starts them (a camera host's restart: 16 Chess
  // PNGs took 0.43 s one by one); the first frame waits for it.
  std::future<cv::Mat> still;
  lf::SyntheticScene scene;
  guint64 frame = 0;
  // file / v4l2 modes: GStreamer's decoders (gst/lfcamerainput.h).
  std::unique_ptr<lfgst::DecodedInput> decoder;
  GstBuffer* last = nullptr;  // newest decoded frame (not the sample: appsink reuses those)
  guint64 skipped = 0;        // skip-bad-frames: frames skipped so far
  // File mode with PNG or JPEG stills (one file, or a sequence): decoded here
  // (lib/lf/io/image_io.h), so a damaged, truncated or wrong-sized frame is
  // an error naming its file.
  std::optional<lf::StillSequence> stills;
  ~State() {
    if (last) gst_buffer_unref(last);
  }
};

struct Priv {
  Settings settings;  // properties (object lock)
  std::unique_ptr<State> state;
  lfgst::ClockWaiter waiter;
};

lfgst::Properties<Settings> props;
}  // namespace

struct _LfCamSrc {
  GstPushSrc parent;
  Priv* priv;
};

G_DEFINE_TYPE(LfCamSrc, lf_cam_src, GST_TYPE_PUSH_SRC)
GST_ELEMENT_REGISTER_DEFINE(lfcamsrc, "lfcamsrc", GST_RANK_NONE, LF_TYPE_CAM_SRC)

static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE(
    "src", GST_PAD_SRC, GST_PAD_ALWAYS,
    GST_STATIC_CAPS("video/x-raw, format = (string) RGBA, width = (int) [ 2, 65535 ], "
                    "height = (int) [ 2, 65535 ], framerate = (fraction) [ 1/1, 1000/1 ]"));

static void lf_cam_src_property_set(GObject* obj, GParamSpec* ps, const GValue* v) {
  lfgst::apply_is_live(obj, ps, v);
}
LF_DEFINE_ELEMENT_GLUE(lf_cam_src, LF_CAM_SRC)

using lfgst::make_element;

// Opens the camera's input for `st` (throws std::exception on failure).
// `self` outlives the still's decoding: State's destructor waits for it.
static void open_input(GstElement* self, State* st) {
  const Settings& s = st->s;
  const lf::Camera& cam = st->rig->cameras[st->index];
  switch (s.mode) {
    case Mode::kFile:
    case Mode::kV4l2: {
      if (s.mode == Mode::kFile && s.location.empty())
        throw std::invalid_argument(
            "mode=file needs 'location' (a file, or a printf pattern such as frames/%04d.png "
            "for an image sequence)");
      if (s.location.find('%') != std::string::npos)
        lf::camera_file_name(s.location, 0, "location");  // throws naming a bad pattern
      if (lf::StillSequence seq(s.location, cam.width, cam.height, s.loop, s.skip_bad_frames);
          lf::is_still_image(seq.path(0))) {
        st->stills.emplace(std::move(seq));
        st->rgba = cv::Mat(cam.height, cam.width, CV_8UC4);  // size for caps
        break;
      }
      // Errors surface here, when the element starts (a missing file, a
      // busy device, an undecodable stream), not later as a missing frame.
      st->decoder = std::make_unique<lfgst::DecodedInput>(
          lfgst::DecodedInput::Options{s.mode == Mode::kV4l2, s.location, s.device, s.loop,
                                       s.skip_bad_frames, cam.width, cam.height});
      st->rgba = cv::Mat(cam.height, cam.width, CV_8UC4);  // size for caps
      break;
    }
    case Mode::kSynthetic:
      st->scene = lf::SyntheticScene::for_rig(*st->rig);
      st->rgba = cv::Mat(cam.height, cam.width, CV_8UC4);  // size for caps
      break;
    case Mode::kDataset: {
      if (cam.image.empty())
        throw std::invalid_argument("camera " + std::to_string(cam.id) +
                                    " has no image file (use mode=synthetic)");
      // A missing file fails here, when the element starts; one that does
      // not decode, at the first frame.
      if (!g_file_test(cam.image.c_str(), G_FILE_TEST_IS_REGULAR))
        throw std::runtime_error("image " + cam.image + ": missing or unreadable");
      st->rgba = cv::Mat(cam.height, cam.width, CV_8UC4);  // size for caps
      lf::StillCache cache;
      cache.dir = s.still_cache;
      st->still = std::async(std::launch::async, [cam, cache, self] {
        const lf::DecodeSlot slot;
        lf::StillSource from = lf::StillSource::kDecoded;
        std::string note;
        cv::Mat rgba = lf::cached_still(
            cache, cam.image, cam.width, cam.height, CV_8UC4,
            [&cam] { return lf::read_camera_image(cam.image, cam.width, cam.height); }, &from,
            &note);
        GST_DEBUG_OBJECT(self, "still of camera %d %s", cam.id,
                         from == lf::StillSource::kCache ? "read from the cache" : "decoded");
        if (!note.empty()) GST_WARNING_OBJECT(self, "still cache: %s", note.c_str());
        return rgba;
      });
      break;
    }
  }
}

static gboolean lf_cam_src_start(GstBaseSrc* src) {
  LfCamSrc* self = LF_CAM_SRC(src);
  auto st = std::make_unique<State>();
  st->s = lfgst::snapshot(GST_OBJECT(self), self->priv->settings);
  st->rig = lfgst::open_rig(GST_ELEMENT(self), st->s.rig);
  if (!st->rig) return FALSE;
  st->index = lfgst::camera_index(GST_ELEMENT(self), *st->rig, st->s);
  if (st->index < 0) return FALSE;
  GError* err = nullptr;
  if (!lfgst::guard([&] { open_input(GST_ELEMENT(self), st.get()); }, &err)) {
    GST_ELEMENT_ERROR(self, RESOURCE, OPEN_READ, ("Cannot open the camera"), ("%s", err->message));
    g_error_free(err);
    return FALSE;
  }
  self->priv->state = std::move(st);
  return TRUE;
}

static gboolean lf_cam_src_stop(GstBaseSrc* src) {
  LF_CAM_SRC(src)->priv->state.reset();
  return TRUE;
}

static GstCaps* lf_cam_src_get_caps(GstBaseSrc* src, GstCaps* filter) {
  LfCamSrc* self = LF_CAM_SRC(src);
  GstCaps* caps;
  if (State* st = self->priv->state.get()) {
    caps = gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, "RGBA", "width", G_TYPE_INT,
                               st->rgba.cols, "height", G_TYPE_INT, st->rgba.rows, "framerate",
                               GST_TYPE_FRACTION, st->s.framerate.n, st->s.framerate.d, nullptr);
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

LF_DEFINE_SRC_UNLOCK(lf_cam_src, LF_CAM_SRC)

static void free_mat(gpointer p) {
  delete static_cast<cv::Mat*>(p);
}

// File mode with PNG or JPEG stills: the next frame of the sequence (or the
// one still) into st->rgba (lf::StillSequence); at the end EOS, or the first
// frame again with loop; a frame that does not decode is an error naming it,
// or with skip-bad-frames a warning.
static GstFlowReturn next_still(LfCamSrc* self, State* st) {
  using What = lf::StillSequence::Next::What;
  const lf::StillSequence::Next n = st->stills->next(&st->rgba);
  for (const std::string& why : n.skipped)
    GST_ELEMENT_WARNING(self, STREAM, DECODE, ("Skipped a frame that does not decode"),
                        ("%s (%" G_GUINT64_FORMAT " skipped so far)", why.c_str(), ++st->skipped));
  if (n.what == What::kMissing)
    GST_ELEMENT_ERROR(self, RESOURCE, NOT_FOUND, ("No frame in the camera input"),
                      ("%s", n.error.c_str()));
  if (n.what == What::kUndecodable)
    GST_ELEMENT_ERROR(self, STREAM, DECODE, ("Cannot decode the camera input"),
                      ("%s", n.error.c_str()));
  return n.what == What::kEnd                                       ? GST_FLOW_EOS
         : n.what == What::kMissing || n.what == What::kUndecodable ? GST_FLOW_ERROR
                                                                    : GST_FLOW_OK;
}

static GstFlowReturn lf_cam_src_create(GstPushSrc* src, GstBuffer** out) {
  LfCamSrc* self = LF_CAM_SRC(src);
  State* st = self->priv->state.get();
  const Settings& set = st->s;
  const GstClockTime period =
      gst_util_uint64_scale_int(GST_SECOND, set.framerate.d, set.framerate.n);
  if (set.live)
    st->frame = lfgst::first_current_tick(GST_ELEMENT(src), st->frame, period, set.phase);
  const GstClockTime pts = st->frame * period + set.phase;
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
  if (set.live && !self->priv->waiter.wait_until(GST_ELEMENT(src), pts)) return GST_FLOW_FLUSHING;
  if (st->stills) {
    const GstFlowReturn r = next_still(self, st);
    if (r != GST_FLOW_OK) return r;
  } else if (st->decoder) {
    // File: the next decoded frame (looping a plain file on EOS if asked);
    // V4L2 (live): the newest frame at the capture instant.
    lfgst::DecodedInput::Next n = st->decoder->next(st->last != nullptr);
    for (const std::string& b : n.skipped)
      GST_ELEMENT_WARNING(self, STREAM, DECODE, ("Skipped a frame that does not decode"),
                          ("%s (%" G_GUINT64_FORMAT " skipped so far)", b.c_str(), ++st->skipped));
    if (!n.error.empty()) {
      GST_ELEMENT_ERROR(self, STREAM, DECODE, ("Cannot decode the camera input"),
                        ("%s: %s%s", set.location.c_str(), n.error.c_str(),
                         set.skip_bad_frames ? "" : " (skip-bad-frames=true skips such frames)"));
      if (!st->last) return GST_FLOW_ERROR;
    }
    if (n.end && !st->last) {
      // The end before a single frame: nothing in the file decoded (a
      // damaged still, a sequence of damaged frames).
      GST_ELEMENT_ERROR(self, STREAM, DECODE, ("No frame in the camera input"),
                        ("%s: the input ended before a frame decoded", set.location.c_str()));
      return GST_FLOW_ERROR;
    }
    if (n.end) return GST_FLOW_EOS;
    GstSample* s = n.sample;
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
  if (st->still.valid()) {
    GError* err = nullptr;
    if (!lfgst::guard([&] { st->rgba = st->still.get(); }, &err)) {
      GST_ELEMENT_ERROR(self, RESOURCE, READ, ("Cannot read the camera image"),
                        ("%s", err->message));
      g_error_free(err);
      return GST_FLOW_ERROR;
    }
  }
  auto* ref = new cv::Mat(set.mode == Mode::kSynthetic
                              ? st->scene.render(st->rig->cameras[st->index], pts / 1e9)
                              : st->rgba);
  if (set.noise > 0)  // seeded by camera and frame: the same run gives the same frames
    *ref = lf::with_sensor_noise(*ref, set.noise, st->rig->cameras[st->index].id, st->frame);
  GstBuffer* buf = gst_buffer_new_wrapped_full(GST_MEMORY_FLAG_READONLY, ref->data,
                                               ref->total() * ref->elemSize(), 0,
                                               ref->total() * ref->elemSize(), ref, free_mat);
  *out = stamp(buf);
  return GST_FLOW_OK;
}

static gboolean lf_cam_src_event(GstBaseSrc* src, GstEvent* event) {
  if (lfgst::refuse_seek(GST_ELEMENT(src), event)) return FALSE;
  return GST_BASE_SRC_CLASS(lf_cam_src_parent_class)->event(src, event);
}

static gboolean lf_cam_src_query(GstBaseSrc* src, GstQuery* q) {
  if (lfgst::answer_live_latency(src, q)) return TRUE;
  return GST_BASE_SRC_CLASS(lf_cam_src_parent_class)->query(src, q);
}

static void lf_cam_src_init(LfCamSrc* self) {
  self->priv = new Priv();
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
  const GParamFlags rw = lfgst::kReadWriteReady;
  props.add(oc, &Settings::rig,
            g_param_spec_string("rig", "Rig", "Rig file (.json) or dataset folder", nullptr, rw));
  lfgst::add_camera_properties(props, oc);
  props.add(oc, &Settings::framerate,
            gst_param_spec_fraction("framerate", "Frame rate", "Capture rate, frames per second", 1,
                                    1, 1000, 1, DEFAULT_FPS_N, DEFAULT_FPS_D, rw));
  props.add(oc, &Settings::phase,
            g_param_spec_uint64("phase", "Phase",
                                "Capture schedule offset, ns: frame k is captured at running "
                                "time k * period + phase",
                                0, G_MAXUINT64, DEFAULT_PHASE, rw));
  props.add(oc, &Settings::live,
            g_param_spec_boolean("is-live", "Live",
                                 "Capture in real time on the pipeline clock's schedule",
                                 DEFAULT_IS_LIVE, rw));
  props.add(oc, &Settings::mode,
            g_param_spec_enum("mode", "Mode", "Where frames come from", LF_TYPE_CAM_SRC_MODE,
                              static_cast<gint>(DEFAULT_MODE), rw));
  props.add(oc, &Settings::location,
            g_param_spec_string("location", "Location",
                                "mode=file: a video file or URI, or a printf pattern of an image "
                                "sequence (frames/%04d.png)",
                                nullptr, rw));
  props.add(
      oc, &Settings::device,
      g_param_spec_string("device", "Device", "mode=v4l2: the capture device", DEFAULT_DEVICE, rw));
  props.add(oc, &Settings::noise,
            g_param_spec_double("noise", "Sensor noise",
                                "Gaussian sensor noise added to the dataset and synthetic "
                                "modes' frames: standard deviation in 8-bit levels, per colour "
                                "channel and pixel, seeded by camera id and frame number (0: none)",
                                0.0, 64.0, DEFAULT_NOISE, rw));
  props.add(oc, &Settings::still_cache,
            g_param_spec_string(
                "still-cache", "Still cache",
                "mode=dataset: directory where decoded stills are kept (at most 1 GiB, the least "
                "recently used removed first), so that a restart reads them instead of decoding "
                "the image files again; a changed image file is decoded again. Empty: no cache",
                default_still_cache().c_str(), rw));
  props.add(oc, &Settings::skip_bad_frames,
            g_param_spec_boolean(
                "skip-bad-frames", "Skip bad frames",
                "mode=file: a frame the decoder cannot decode is skipped with a warning naming "
                "it and the count so far (default: an error naming the file and frame)",
                FALSE, rw));
  props.add(
      oc, &Settings::loop,
      g_param_spec_boolean("loop", "Loop", "mode=file: start again at the end", DEFAULT_LOOP, rw));
  gst_type_mark_as_plugin_api(LF_TYPE_CAM_SRC_MODE, static_cast<GstPluginAPIFlags>(0));
  gst_element_class_add_static_pad_template(ec, &src_template);
  gst_element_class_set_static_metadata(
      ec, "Light field camera source", "Source/Video",
      "One camera of a light field rig (dataset stills as video, a synthetic dynamic scene, a "
      "video file or a V4L2 device), captured on a clock-aligned schedule",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfcamsrc rig=../shared/data/stanford-chess row=4 col=4 num-buffers=30 ! "
      "videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Error message when the rig, the camera or the input (file, device, still) cannot be opened "
      "or decoded, naming it; with skip-bad-frames=true a damaged frame of an image sequence is a "
      "counted warning instead. Each buffer carries an LfCaptureMeta (camera-id, capture-time, "
      "ns).");
  bc->start = lf_cam_src_start;
  bc->stop = lf_cam_src_stop;
  bc->get_caps = lf_cam_src_get_caps;
  bc->unlock = lf_cam_src_unlock;
  bc->unlock_stop = lf_cam_src_unlock_stop;
  bc->query = lf_cam_src_query;
  bc->event = lf_cam_src_event;
  pc->create = lf_cam_src_create;
  GST_DEBUG_CATEGORY_INIT(lf_cam_src_debug, "lfcamsrc", 0, "light field camera source");
}
