// lffragment: the paper's random access camera (Yang et al. 2002, Section
// 4.2). The element's documentation, properties and metadata (what
// gst-inspect-1.0 and docs/elements.md show) are in gst/lffragmentprops.cpp;
// the camera's frames are lf::CameraFrames (lib/lf/session/camera_frames.h)
// and its answers lf::CameraAnswer (lib/lf/session/camera_host.h). This file
// is the glue: pads, events, the request thread, buffers and metas.
#include <gst/video/video.h>

#include <chrono>
#include <memory>
#include <new>
#include <string>

#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/render/colour.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/session/camera_frames.h"
#include "lf/session/camera_host.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"
#include "lfbackend.h"
#include "lfcaps.h"
#include "lffragmentprops.h"
#include "lfguard.h"
#include "lfmemory.h"
#include "lfmeta.h"
#include "lfprops.h"
#include "lfrate.h"
#include "lfrig.h"
#include "lftrace.h"
#include "lfwarn.h"

GST_DEBUG_CATEGORY_STATIC(lf_fragment_debug);
#define GST_CAT_DEFAULT lf_fragment_debug

G_BEGIN_DECLS
#define LF_TYPE_FRAGMENT (lf_fragment_get_type())
G_DECLARE_FINAL_TYPE(LfFragment, lf_fragment, LF, FRAGMENT, GstElement)
G_END_DECLS

namespace {
using Settings = lfgst::FragmentSettings;
using Encoding = lfgst::FragmentEncoding;
using FrameSelect = lfgst::FrameSelect;
// Frames kept: frame-select=capture-time (a request up to this many frames
// behind the camera); else enough for a probe reaching a busy camera late
// (1080p JPEG, 2 cores: with two, half the cameras sat surface probes out).
constexpr size_t kFrameRing = 8, kProbeRing = 4;

// From READY->PAUSED to PAUSED->READY.
struct State {
  Settings s;  // snapshot taken at READY->PAUSED
  std::shared_ptr<const lf::Rig> rig;
  int index = -1;
  // The frame as warped (colour-corrected or made opaque), once per frame.
  lf::CorrectedFrame corrected;
  // The request limits: max_rate requests and (live) max_pixel_rate output
  // pixels a second for each viewer, bursts of one second's worth (request
  // thread only).
  lfgst::RequestLimits limits;
  // The renderer (lib/lf/render/renderer.h: the CPU kernels, or GL), chosen at
  // start by `backend`; its slot 0 holds the camera frame (request thread
  // only).
  std::unique_ptr<lf::Renderer> renderer;
  // encoding=jpeg: the rectangle's image the encoder takes, drawn in place
  // (lf/wire/wire.h serialize_jpeg_fragment), kept from request to request (no
  // allocation per fragment; request thread only).
  std::vector<uint8_t> jpeg_pixels;
  // Warnings about what peers send, at most one a second each.
  lfgst::WarnLimiter bad_request, too_large, too_fast, no_frame, failed;
};

struct Priv {
  Settings settings;  // properties (object lock)
  std::unique_ptr<State> state;
  // The camera's last frames (kFrameRing or kProbeRing) and the waits
  // between its thread and the request thread (lib/lf/session/camera_frames.h).
  lf::CameraFrames<lfgst::BufferRef> frames;
  GMutex lock;  // the camera's format
  GstVideoInfo vinfo;
  bool have_vinfo = false;
  Priv() {
    g_mutex_init(&lock);
    gst_video_info_init(&vinfo);
  }
  ~Priv() { g_mutex_clear(&lock); }
};

lfgst::Properties<Settings> props;
}  // namespace

struct _LfFragment {
  GstElement parent;
  GstPad* sinkpad;
  GstPad* requestpad;
  GstPad* srcpad;
  Priv* priv;
};

G_DEFINE_TYPE(LfFragment, lf_fragment, GST_TYPE_ELEMENT)
GST_ELEMENT_REGISTER_DEFINE(lffragment, "lffragment", GST_RANK_NONE, LF_TYPE_FRAGMENT)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink", GST_PAD_SINK, GST_PAD_ALWAYS,
    GST_STATIC_CAPS("video/x-raw, format = (string) { RGBA, RGBx }, width = (int) [ 2, 65535 ], "
                    "height = (int) [ 2, 65535 ], framerate = (fraction) [ 0/1, MAX ]"));
static GstStaticPadTemplate request_template = GST_STATIC_PAD_TEMPLATE(
    "request", GST_PAD_SINK, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_REQUEST_CAPS));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_FRAGMENT_CAPS));

static void lf_fragment_property_set(GObject*, GParamSpec*, const GValue*) {}
LF_DEFINE_ELEMENT_GLUE(lf_fragment, LF_FRAGMENT)

// ---- camera frames -------------------------------------------------------

// The camera's latency query: live 1, not 0, unknown -1 (no answer).
static int camera_liveness(GstPad* sinkpad) {
  GstQuery* q = gst_query_new_latency();
  int live = -1;
  if (gst_pad_peer_query(sinkpad, q)) {
    gboolean is_live = FALSE;
    gst_query_parse_latency(q, &is_live, nullptr, nullptr);
    live = is_live ? 1 : 0;
  }
  gst_query_unref(q);
  return live;
}

static gboolean lf_fragment_sink_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  LfFragment* self = LF_FRAGMENT(parent);
  Priv* p = self->priv;
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
      if (p->state) {
        const lf::Camera& cam = p->state->rig->cameras[p->state->index];
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
      const int live = camera_liveness(pad);
      g_mutex_lock(&p->lock);
      p->vinfo = info;
      p->have_vinfo = true;
      g_mutex_unlock(&p->lock);
      p->frames.set_camera(
          live, GST_VIDEO_INFO_FPS_N(&info) > 0
                    ? static_cast<int64_t>(gst_util_uint64_scale_int(
                          GST_SECOND, GST_VIDEO_INFO_FPS_D(&info), GST_VIDEO_INFO_FPS_N(&info)))
                    : -1);
      break;
    }
    case GST_EVENT_EOS:
      // The camera stream ending does not end the fragment stream: the
      // newest frame stays in use (stills, or a camera that stopped).
      p->frames.camera_ended();
      break;
    case GST_EVENT_FLUSH_START:
      p->frames.set_flushing(true);
      break;
    case GST_EVENT_FLUSH_STOP:
      p->frames.flush_stop(true);
      break;
    default:
      break;
  }
  gst_event_unref(event);
  return TRUE;
}

static GstFlowReturn lf_fragment_sink_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  LfFragment* self = LF_FRAGMENT(parent);
  State* st = self->priv->state.get();
  const int64_t t =
      st ? lfgst::capture_time_of(buf, st->rig->cameras[st->index].id, GST_OBJECT(self)) : -1;
  using Pushed = lf::CameraFrames<lfgst::BufferRef>::Pushed;
  const Pushed r = self->priv->frames.push(t, lfgst::BufferRef(buf));
  gst_buffer_unref(buf);
  return r == Pushed::kFlushing ? GST_FLOW_FLUSHING
         : r == Pushed::kEnd    ? GST_FLOW_EOS
                                : GST_FLOW_OK;
}

// ---- view requests -------------------------------------------------------

static gboolean lf_fragment_request_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  LfFragment* self = LF_FRAGMENT(parent);
  switch (GST_EVENT_TYPE(event)) {
    case GST_EVENT_CAPS: {
      GstCaps* in;
      gst_event_parse_caps(event, &in);
      const Encoding enc =
          lfgst::read_setting(GST_OBJECT(self), self->priv->settings, &Settings::encoding);
      GstEvent* out = lfgst::shared_fragment_caps_event(in, enc);
      gst_event_unref(event);
      return gst_pad_push_event(self->srcpad, out);
    }
    case GST_EVENT_FLUSH_START:
      self->priv->frames.set_flushing(true);
      return gst_pad_push_event(self->srcpad, event);
    case GST_EVENT_FLUSH_STOP:
      self->priv->frames.flush_stop(false);
      return gst_pad_push_event(self->srcpad, event);
    case GST_EVENT_EOS:
      // Every request is answered (the request chain runs before this
      // event): the fragment stream ends, and so does the camera's.
      self->priv->frames.requests_ended();  // a camera held for being ahead goes on, to its EOS
      return gst_pad_event_default(pad, parent, event);
    default:
      return gst_pad_event_default(pad, parent, event);
  }
}

// Requests beyond the element's limits (a view larger than max-pixels, more
// than max-rate requests a second, or more than max-pixel-rate output
// pixels a second, for their viewer) are dropped with a warning: a peer
// must not make a camera host allocate or compute without bound, nor take
// another viewer's share. The pixel budget shares a live host's time; a
// non-live pipeline renders every request.
static bool admit(LfFragment* self, State* st, const lf::ViewRequest& req) {
  const Settings& s = st->s;
  return lfgst::admit_or_warn(
      GST_ELEMENT(self), st->limits, st->too_fast, req.viewer_id, s.max_rate, s.max_pixel_rate,
      static_cast<double>(req.view.width) * req.view.height, self->priv->frames.live() != 0,
      static_cast<double>(s.max_pixels), &st->too_large);
}

// An explicitly empty fragment of camera `cam` for `req` (lf::empty_answer).
static GstBuffer* empty_fragment(const lf::ViewRequest& req, const lf::Camera& cam,
                                 int64_t capture_time_ns) {
  const std::vector<uint8_t> bytes = lf::empty_answer(req, cam.id, capture_time_ns);
  return gst_buffer_new_memdup(bytes.data(), bytes.size());
}

// Answers one request (a frame request, or one step of a probe) that came
// in `buf` (timestamps): *answer gets its fragment buffer, or stays null
// where the request is dropped (with a warning where due).
static GstFlowReturn answer_request(LfFragment* self, const lf::ViewRequest& req,
                                    const std::string& key, GstBuffer* buf, GstBuffer** answer) {
  Priv* p = self->priv;
  State* st = p->state.get();
  GError* err = nullptr;
  if (!admit(self, st, req)) return GST_FLOW_OK;
  const lf::Rig& rig = *st->rig;
  const lf::Camera& cam = rig.cameras[st->index];
  lfgst::trace(GST_ELEMENT(self), "request-in", req.viewer_id, req.sequence, cam.id);
  // The request's time: the one it carries (the viewer's PTS, whatever the
  // network delay), else its buffer's PTS (its arrival time after RTP). A
  // probe's steps (focus or surface) must all see the frames of one capture
  // instant, in every camera: by capture time whatever frame-select says,
  // and one frame for all steps of a probe; a live camera that no longer
  // holds the probe's instant, or skipped it, sits the probe out (the scene
  // moves: cameras seeing it at different instants disagree at the true
  // depth). A wait for a frame ends with a frame, the camera's end,
  // flushing or PAUSED->READY; from a live camera after frame-timeout.
  lf::CameraFrames<lfgst::BufferRef>::Want want;
  want.time_ns = req.time_ns >= 0               ? req.time_ns
                 : GST_BUFFER_PTS_IS_VALID(buf) ? static_cast<int64_t>(GST_BUFFER_PTS(buf))
                                                : -1;
  want.by_capture_time = st->s.frame_select == FrameSelect::kCaptureTime;
  const bool probe = lf::is_focus_probe(req.sequence) || lf::is_surface_probe(req.sequence);
  if (probe) want.probe = req.sequence >> 16;  // the probe without its step
  // Before the camera's caps (still starting): is it live? A non-live one
  // gets ten timeouts to start (the demo's stall, 1 run in 5).
  if (p->frames.live() < 0) p->frames.set_live(camera_liveness(self->sinkpad));
  const auto pick = p->frames.pick(want, std::chrono::nanoseconds(st->s.frame_timeout));
  if (pick.flushing) return GST_FLOW_FLUSHING;
  GstBuffer* frame = pick.frame ? gst_buffer_ref(pick.frame.get()) : nullptr;
  const int64_t req_time = want.time_ns;
  g_mutex_lock(&p->lock);
  GstVideoInfo info = p->vinfo;
  const bool have_info = p->have_vinfo;
  g_mutex_unlock(&p->lock);
  // An explicitly empty answer, as from a camera that sees none of the
  // view: the compositor knows this camera answered.
  auto answer_empty = [&] {
    *answer = empty_fragment(req, cam, -1);
    gst_buffer_copy_into(*answer, buf, GST_BUFFER_COPY_TIMESTAMPS, 0, -1);
    GST_BUFFER_OFFSET(*answer) = req.sequence;
  };
  if (!frame && probe && req_time >= 0 && have_info) {
    // Sat out: a non-live pipeline would otherwise wait for this camera for
    // ever, and the probe is scored without its pixels in every step.
    GST_DEBUG_OBJECT(self, "probe %" G_GUINT64_FORMAT ": its instant is no longer here, sat out",
                     req.sequence);
    answer_empty();
    return GST_FLOW_OK;
  }
  // defer (lfarray's whole-view mode, one request thread for all cameras)
  // or answer-empty: a request this camera cannot answer gets an empty answer, so
  // every camera's pad of a non-live compositor stays in step (a pad left
  // without the fragment that the others have would hold GstAggregator,
  // and with it the request thread, for ever).
  GstVideoFrame vf;
  if (!frame || !have_info || !gst_video_frame_map(&vf, &info, frame, GST_MAP_READ)) {
    LF_ELEMENT_WARNING_LIMITED(
        self, st->no_frame, STREAM, FAILED, ("No camera frame: dropping the request"),
        "camera %d delivered no frame within %" GST_TIME_FORMAT " (request %" G_GUINT64_FORMAT ")",
        cam.id, GST_TIME_ARGS(st->s.frame_timeout), req.sequence);
    if (frame) gst_buffer_unref(frame);
    if (st->s.defer || st->s.answer_empty) answer_empty();
    return GST_FLOW_OK;
  }
  const gint quality = lfgst::read_setting(GST_OBJECT(self), p->settings, &Settings::quality);
  GstBuffer* out = nullptr;
  const gboolean ok = lfgst::guard(
      [&] {
        const cv::Mat image(GST_VIDEO_FRAME_HEIGHT(&vf), GST_VIDEO_FRAME_WIDTH(&vf), CV_8UC4,
                            GST_VIDEO_FRAME_PLANE_DATA(&vf, 0),
                            GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 0));
        const cv::Mat rgba = st->corrected.get(
            cam, frame, image, GST_VIDEO_INFO_FORMAT(&info) == GST_VIDEO_FORMAT_RGBx);
        lf::Fragment f;  // the header fields every fragment of the answer shares
        f.viewer_id = req.viewer_id;
        f.sequence = req.sequence;
        f.capture_time_ns = lfgst::capture_time_of(frame, cam.id, GST_OBJECT(self));
        // The camera's plans (lib/lf/session/camera_host.h): one, a layer
        // pair, or a quilt's eyes; the geometry shared with the process's
        // other cameras where it pays (a quilt's eyes each have their own).
        lf::CameraAnswer answer(
            rig, req, st->index,
            req.quilt.empty() ? lf::shared_geometry(st->rig, req, st->index, key) : nullptr);
        // defer (lfarray's whole-view mode): the plan (a layer pair's two) and the image go on
        // an empty fragment to the compositor (probes, scored from pixels, are drawn here).
        const size_t n = answer.count();
        const bool deferred = st->s.defer && st->s.encoding == Encoding::kRaw && !probe &&
                              !answer.quilt() && (n == 1 || n == 2);
        // Sees none of a quilt's eyes, or (deferred) of the view, as most cameras: nothing to draw.
        const bool nothing = (answer.quilt() || deferred) && answer.sees_nothing();
        if (nothing || (deferred && !answer.plan(0).empty())) {
          out = empty_fragment(req, cam, f.capture_time_ns);
          if (nothing) return;
          lfgst::add_deferred_meta(
              out, lfgst::deferred_draw(frame, info, rgba.data == image.data ? cv::Mat() : rgba,
                                        cam, st->index, answer.take_plan(0),
                                        n == 2 ? answer.take_plan(1) : lf::FragmentPlan{}));
          lfgst::trace(GST_ELEMENT(self), "warped", req.viewer_id, req.sequence, cam.id, 0);
          lfgst::trace(GST_ELEMENT(self), "encoded", req.viewer_id, req.sequence, cam.id,
                       static_cast<gint64>(gst_buffer_get_size(out)));
          return;
        }
        st->renderer->set_image(0, rgba, frame, GST_BUFFER_PTS(frame));
        if (st->s.encoding == Encoding::kJpeg) {
          const std::vector<uint8_t> bytes =
              answer.encode_jpeg(f, cam, *st->renderer, 0, quality, st->jpeg_pixels);
          out = gst_buffer_new_memdup(bytes.data(), bytes.size());
        } else {
          // Raw: rendered straight into the output buffer, in its wire
          // format (no copy of the pixels).
          const std::vector<lf::Fragment> heads = answer.headers(f, cam.id);
          const size_t size = lf::CameraAnswer::raw_size(heads);
          if (!(out = lfgst::new_buffer(size))) throw std::bad_alloc();
          lfgst::add_sealed_meta(out);  // while it is writable (sealed by write_raw)
          lfgst::MappedBuffer map(out, GST_MAP_WRITE);
          answer.write_raw(heads, cam, *st->renderer, 0, map.data(), size);
        }
        lfgst::trace(GST_ELEMENT(self), "warped", req.viewer_id, req.sequence, cam.id,
                     static_cast<gint64>(answer.pixel_count()));
        lfgst::trace(GST_ELEMENT(self), "encoded", req.viewer_id, req.sequence, cam.id,
                     static_cast<gint64>(gst_buffer_get_size(out)));
      },
      &err);
  gst_video_frame_unmap(&vf);
  gst_buffer_unref(frame);
  if (!ok) {
    // A request this camera cannot answer (e.g. a payload over the wire
    // format's limit) is dropped: the compositor renormalises without it.
    LF_ELEMENT_WARNING_LIMITED(self, st->failed, STREAM, FAILED,
                               ("Cannot render the fragment: dropping the request"),
                               "request %" G_GUINT64_FORMAT " of viewer %u: %s", req.sequence,
                               req.viewer_id, err->message);
    g_error_free(err);
    if (out) gst_buffer_unref(out);
    if (st->s.defer || st->s.answer_empty) answer_empty();
    return GST_FLOW_OK;
  }
  gst_buffer_copy_into(out, buf, GST_BUFFER_COPY_TIMESTAMPS, 0, -1);
  GST_BUFFER_OFFSET(out) = req.sequence;
  *answer = out;
  return GST_FLOW_OK;
}

// A request buffer: one request, answered in one buffer (a layer pair where
// the surface has second planes), or a probe bundle (lib/lf/wire/probe_bundle.h),
// whose steps are answered one by one and sent back in one buffer.
static GstFlowReturn lf_fragment_request_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  LfFragment* self = LF_FRAGMENT(parent);
  State* st = self->priv->state.get();
  // Each request with its bytes, to share what it needs (lf::shared_geometry).
  std::shared_ptr<const lf::KeyedRequests> reqs;
  GError* err = nullptr;
  if (!lfgst::guard(
          [&] {
            const lfgst::MappedBuffer map(buf, GST_MAP_READ);
            reqs = lf::shared_keyed_requests(map.data(), map.size());
          },
          &err)) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad_request, STREAM, DECODE,
                               ("Dropping a malformed view request"), "%s", err->message);
    g_error_free(err);
    gst_buffer_unref(buf);
    return GST_FLOW_OK;
  }
  GstBuffer* bundle = nullptr;
  for (const auto& [req, key] : *reqs) {
    GstBuffer* out = nullptr;
    const GstFlowReturn ret = answer_request(self, req, key, buf, &out);
    if (ret != GST_FLOW_OK) {
      if (bundle) gst_buffer_unref(bundle);
      gst_buffer_unref(buf);
      return ret;
    }
    if (out) bundle = bundle ? gst_buffer_append(bundle, out) : out;
  }
  gst_buffer_unref(buf);
  return bundle ? gst_pad_push(self->srcpad, bundle) : GST_FLOW_OK;
}

static gboolean lf_fragment_start(LfFragment* self) {
  auto st = std::make_unique<State>();
  st->s = lfgst::snapshot(GST_OBJECT(self), self->priv->settings);
  st->rig = lfgst::open_rig(GST_ELEMENT(self), st->s.rig);
  if (!st->rig) return FALSE;
  st->index = lfgst::camera_index(GST_ELEMENT(self), *st->rig, st->s);
  if (st->index < 0) return FALSE;
  if (!lfgst::open_renderer(GST_ELEMENT(self), st->s.backend, st->renderer)) return FALSE;
  // Probes pick by capture time whatever the mode.
  const bool by_time = st->s.frame_select == FrameSelect::kCaptureTime;
  self->priv->frames.set_keep(by_time ? kFrameRing : kProbeRing);
  self->priv->state = std::move(st);
  self->priv->frames.set_flushing(false);
  return TRUE;
}

static void lf_fragment_stop(LfFragment* self) {
  Priv* p = self->priv;
  p->frames.reset();
  g_mutex_lock(&p->lock);
  p->have_vinfo = false;
  g_mutex_unlock(&p->lock);
  p->state.reset();
}

static GstStateChangeReturn lf_fragment_change_state(GstElement* el, GstStateChange t) {
  LfFragment* self = LF_FRAGMENT(el);
  if (t == GST_STATE_CHANGE_READY_TO_PAUSED && !lf_fragment_start(self))
    return GST_STATE_CHANGE_FAILURE;
  // Wake a request waiting for a camera frame before the pads deactivate
  // (they wait for the streaming threads to leave).
  if (t == GST_STATE_CHANGE_PAUSED_TO_READY) self->priv->frames.set_flushing(true);
  const GstStateChangeReturn ret = GST_ELEMENT_CLASS(lf_fragment_parent_class)->change_state(el, t);
  if (t == GST_STATE_CHANGE_PAUSED_TO_READY) lf_fragment_stop(self);
  return ret;
}

static void lf_fragment_init(LfFragment* self) {
  self->priv = new Priv();
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
  lfgst::install_fragment_properties(oc, &props);
  gst_element_class_add_static_pad_template(ec, &sink_template);
  gst_element_class_add_static_pad_template(ec, &request_template);
  gst_element_class_add_static_pad_template(ec, &src_template);
  lfgst::describe_fragment(ec);
  ec->change_state = lf_fragment_change_state;
  GST_DEBUG_CATEGORY_INIT(lf_fragment_debug, "lffragment", 0, "light field fragments");
}
