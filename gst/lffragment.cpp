/**
 * SECTION:element-lffragment
 * @title: lffragment
 *
 * The paper's random access camera (Yang et al. 2002, Section 4.2). Camera
 * frames arrive on `sink`, view requests on `request`; for every request the
 * newest frame (colour-corrected by the rig's 3x4 `colour` matrix,
 * lib/lf/render/colour.h) is warped into this camera's fragment of the requested
 * view (lib/lf/render/plan.h, lib/lf/render/render.h) and pushed on `src`, tagged in band
 * (lib/lf/wire/wire.h). With `frame-select=capture-time` the frame is instead the
 * one captured at the request's time: the newest whose capture time (its
 * `LfCaptureMeta`, else its PTS) is at or before the request's time (the
 * viewer's PTS, carried in the request, lib/lf/wire/wire.h, so network delay does
 * not change it; else the request buffer's PTS), waiting up to
 * `frame-timeout` for it; so every camera of a deployment warps frames of
 * one capture instant for a request, and a live run and the playback of its
 * recording pair the same frames with the same requests (lfcamerahost
 * `record`/`playback`). Focus probes (lib/lf/focus/focus_probe.h) and surface
 * probes (lib/lf/focus/surface_probe.h) come as one buffer of all their steps
 * (lib/lf/wire/probe_bundle.h), answered with one buffer of this camera's
 * fragment of each step; they always pick by capture time, one frame for
 * all steps of a probe; a camera that no longer holds the frame of the
 * probe's instant (its frame period), or skipped it, sits the probe out.
 * Camera frames may come from any upstream element (e.g. `uridecodebin !
 * videoconvert ! videoscale ! video/x-raw,format=RGBA,width=W,height=H !
 * lffragment`); their PTS is then the capture time.
 * Cameras that do not contribute send an explicitly empty fragment, so the
 * compositor knows the request is complete. The fragment caps carry the
 * request caps' `framerate`; the process's lffragments with equal request
 * caps and encoding share one caps event, so a `funnel` joining cameras
 * (lfcamerahost) sends no new caps downstream when it switches between
 * them. Raw fragments are rendered straight into the
 * output buffer in their wire format (no copy) and carry `LfSealedMeta`
 * (gst/lfmeta.h), by which `lfcompositor` in the same process skips their
 * CRC check. With `defer=true` (lfarray's whole-view mode) a raw
 * fragment is only planned here: it leaves as an empty fragment carrying
 * the plan and the camera image (`LfDeferredMeta`), for an `lfcompositor`
 * in the same process to draw.
 *
 * The camera is named like lfcamsrc's: `camera-id`, or `row` and `col` of
 * the rig's grid.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=rig.json num-buffers=30 ! f.request \
 *   lfcamsrc rig=rig.json camera-id=0 ! f.sink \
 *   lffragment name=f rig=rig.json camera-id=0 encoding=jpeg ! fakesink
 * ]|
 */
#include <gst/video/video.h>

#include <deque>
#include <memory>
#include <mutex>
#include <string>

#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/render/colour.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/session/camera_host.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"
#include "lfbackend.h"
#include "lfcaps.h"
#include "lfguard.h"
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
using Encoding = lfgst::FragmentEncoding;
enum class FrameSelect { kNewest = 0, kCaptureTime = 1 };
// Frames kept for frame-select=capture-time (a request may be up to this many
// frames behind the camera).
constexpr size_t kFrameRing = 8;
}  // namespace

#define DEFAULT_ENCODING Encoding::kRaw
#define DEFAULT_JPEG_QUALITY 90
#define DEFAULT_MAX_PIXELS (G_GUINT64_CONSTANT(3840) * 2160)
#define DEFAULT_MAX_RATE 240.0
#define DEFAULT_FRAME_TIMEOUT GST_SECOND
#define DEFAULT_FRAME_SELECT FrameSelect::kNewest
#define DEFAULT_BACKEND lf::Backend::kAuto

#define LF_TYPE_FRAGMENT_ENCODING (lfgst::fragment_encoding_type())

#define LF_TYPE_FRAGMENT_FRAME_SELECT (lf_fragment_frame_select_get_type())
static GType lf_fragment_frame_select_get_type() {
  static GType type = 0;
  static const GEnumValue values[] = {
      {static_cast<gint>(FrameSelect::kNewest), "The newest camera frame when the request comes",
       "newest"},
      {static_cast<gint>(FrameSelect::kCaptureTime),
       "The frame captured at the request's time: the newest with capture time <= the time the "
       "request carries (the viewer's PTS; deterministic: every camera picks the same capture "
       "instant whatever the network delay, and a recording played back pairs the same frames)",
       "capture-time"},
      {0, nullptr, nullptr}};
  return lfgst::enum_type(&type, "LfFragmentFrameSelect", values);
}

#define LF_TYPE_BACKEND (lfgst::backend_type())

namespace {
struct Settings : lfgst::CameraAddress {
  std::string rig;
  Encoding encoding = DEFAULT_ENCODING;
  gint quality = DEFAULT_JPEG_QUALITY;  // mutable in PLAYING: read live
  guint64 max_pixels = DEFAULT_MAX_PIXELS;
  gdouble max_rate = DEFAULT_MAX_RATE;
  gdouble max_pixel_rate = lfgst::kDefaultMaxPixelRate;
  guint64 frame_timeout = DEFAULT_FRAME_TIMEOUT;
  FrameSelect frame_select = DEFAULT_FRAME_SELECT;
  lf::Backend backend = DEFAULT_BACKEND;
  bool defer = false;  // leave the drawing to an lfcompositor in this process
};

// From READY->PAUSED to PAUSED->READY.
struct State {
  Settings s;  // snapshot taken at READY->PAUSED
  std::shared_ptr<const lf::Rig> rig;
  int index = -1;
  // Colour-corrected copy of the newest frame (only when the camera has a
  // correction or the frames are RGBx), made once per frame, not once per
  // request; guarded by Priv::lock.
  GstBuffer* corrected_of = nullptr;  // the frame it was made from (not owned, compared only)
  cv::Mat corrected;
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
  // Camera frames and request waits, guarded by `lock`.
  GMutex lock;
  GCond cond;
  // The last camera frames (kFrameRing for frame-select=capture-time, else
  // two), oldest first, with their capture times (ns); back(): the newest.
  std::deque<std::pair<int64_t, GstBuffer*>> ring;
  // The frame the current probe's first step took (a focus or a surface
  // probe): its other steps use it too, even after newer frames pushed it
  // out of the ring (a busy camera warps the steps while frames keep
  // coming). The probe by its sequence without the step (kind and id).
  uint64_t probe_key = 0;
  GstBuffer* probe_frame = nullptr;
  GstVideoInfo vinfo;
  bool have_vinfo = false;
  bool video_eos = false;
  bool flushing = false;
  // The requests ended: the camera's frames are no longer needed, and its
  // chain answers EOS (a still camera in a non-live pipeline would otherwise
  // push copies of its image for ever, and the pipeline never end).
  bool requests_eos = false;
  // Whether the camera is live (its upstream's latency query), asked at its
  // caps: -1 unknown (no camera linked). Not live: a request waits for its
  // frame without a deadline, as GstAggregator waits without a latency.
  int camera_live = -1;
  // Not live: the camera is held (its chain waits) once it is kAhead frames
  // ahead of the requests, unless a request waits for a frame: a non-live
  // camera (a still repeated, a file) then makes about one frame a request
  // instead of as many as the CPU allows, which starved the warping (64
  // still cameras took 37 s for 60 requests of one viewer).
  static constexpr int kAhead = 2;
  int ahead = 0;    // frames since a request last took one
  int waiting = 0;  // requests waiting for a frame
  // What the waiting request needs: a frame captured after `want` (ns), or
  // any frame. Once the ring has it, the camera is held again: a camera
  // left to run while the request thread woke up made hundreds of frames
  // (it takes the lock back before the woken thread runs).
  static constexpr int64_t kAnyFrame = INT64_MIN;
  int64_t want = kAnyFrame;
  bool wanted_is_here() const {
    return !ring.empty() && (want == kAnyFrame || ring.back().first > want);
  }
  Priv() {
    g_mutex_init(&lock);
    g_cond_init(&cond);
    gst_video_info_init(&vinfo);
  }
  void clear_ring() {
    for (auto& f : ring) gst_buffer_unref(f.second);
    ring.clear();
    gst_buffer_replace(&probe_frame, nullptr);
  }
  ~Priv() {
    clear_ring();
    g_mutex_clear(&lock);
    g_cond_clear(&cond);
  }
  void set_flushing(bool f) {
    g_mutex_lock(&lock);
    flushing = f;
    g_cond_broadcast(&cond);
    g_mutex_unlock(&lock);
  }
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
      GstQuery* q = gst_query_new_latency();
      int live = -1;
      if (gst_pad_peer_query(pad, q)) {
        gboolean is_live = FALSE;
        gst_query_parse_latency(q, &is_live, nullptr, nullptr);
        live = is_live ? 1 : 0;
      }
      gst_query_unref(q);
      g_mutex_lock(&p->lock);
      p->vinfo = info;
      p->have_vinfo = true;
      p->camera_live = live;
      g_mutex_unlock(&p->lock);
      break;
    }
    case GST_EVENT_EOS:
      // The camera stream ending does not end the fragment stream: the
      // newest frame stays in use (stills, or a camera that stopped).
      g_mutex_lock(&p->lock);
      p->video_eos = true;
      g_cond_broadcast(&p->cond);
      g_mutex_unlock(&p->lock);
      break;
    case GST_EVENT_FLUSH_START:
      p->set_flushing(true);
      break;
    case GST_EVENT_FLUSH_STOP:
      g_mutex_lock(&p->lock);
      p->flushing = false;
      p->video_eos = false;
      p->requests_eos = false;
      g_mutex_unlock(&p->lock);
      break;
    default:
      break;
  }
  gst_event_unref(event);
  return TRUE;
}

static int64_t capture_time_of(LfFragment* self, GstBuffer* frame, int camera_id);

static GstFlowReturn lf_fragment_sink_chain(GstPad*, GstObject* parent, GstBuffer* buf) {
  LfFragment* self = LF_FRAGMENT(parent);
  Priv* p = self->priv;
  State* st = p->state.get();
  // The ring: the last kFrameRing frames for frame-select=capture-time,
  // else the last two (focus probes pick by capture time whatever the mode).
  const size_t keep = st && st->s.frame_select == FrameSelect::kCaptureTime ? kFrameRing : 2;
  const int64_t t = st ? capture_time_of(self, buf, st->rig->cameras[st->index].id) : -1;
  g_mutex_lock(&p->lock);
  const bool flushing = p->flushing;
  if (!flushing) {
    p->ring.emplace_back(t, gst_buffer_ref(buf));
    while (p->ring.size() > keep) {
      gst_buffer_unref(p->ring.front().second);
      p->ring.pop_front();
    }
    g_cond_broadcast(&p->cond);
    ++p->ahead;
    while (p->camera_live == 0 && p->ahead >= Priv::kAhead &&
           (p->waiting == 0 || p->wanted_is_here()) && !p->flushing && !p->requests_eos)
      g_cond_wait(&p->cond, &p->lock);
  }
  const bool done = p->requests_eos;
  g_mutex_unlock(&p->lock);
  gst_buffer_unref(buf);
  return flushing ? GST_FLOW_FLUSHING : done ? GST_FLOW_EOS : GST_FLOW_OK;
}

// ---- view requests -------------------------------------------------------

// The fragment caps event for request caps `in` and encoding `enc`: one
// GstEvent for all the process's lffragments with equal request caps and
// encoding (a new reference). A funnel joining cameras' fragments
// (lfcamerahost) forwards a pad's sticky events whenever it switches pads,
// and a sticky event only goes downstream when it is another GstEvent than
// the one before: with an equal but distinct caps event per camera, caps
// went down with nearly every fragment and each made rtpgstpay negotiate
// again (15 % of a camera host's CPU in the emulated deployment, perf).
static GstEvent* shared_caps_event(const GstCaps* in, Encoding enc) {
  struct Entry {
    GstCaps* in;
    Encoding enc;
    GstEvent* out;
  };
  // The newest last, at most kCaps; its references dropped at exit.
  struct Cache {
    std::mutex m;
    std::deque<Entry> entries;
    void drop_front() {
      gst_caps_unref(entries.front().in);
      gst_event_unref(entries.front().out);
      entries.pop_front();
    }
    ~Cache() {
      while (!entries.empty()) drop_front();
    }
  };
  constexpr size_t kCaps = 8;
  static Cache cache;
  std::lock_guard<std::mutex> lock(cache.m);
  for (const Entry& e : cache.entries)
    if (e.enc == enc && gst_caps_is_equal(e.in, in)) return gst_event_ref(e.out);
  GstCaps* caps = lfgst::fragment_caps(enc, in);
  cache.entries.push_back({gst_caps_copy(in), enc, gst_event_new_caps(caps)});
  gst_caps_unref(caps);
  if (cache.entries.size() > kCaps) cache.drop_front();
  return gst_event_ref(cache.entries.back().out);
}

static gboolean lf_fragment_request_event(GstPad* pad, GstObject* parent, GstEvent* event) {
  LfFragment* self = LF_FRAGMENT(parent);
  switch (GST_EVENT_TYPE(event)) {
    case GST_EVENT_CAPS: {
      GstCaps* in;
      gst_event_parse_caps(event, &in);
      const Encoding enc =
          lfgst::read_setting(GST_OBJECT(self), self->priv->settings, &Settings::encoding);
      GstEvent* out = shared_caps_event(in, enc);
      gst_event_unref(event);
      return gst_pad_push_event(self->srcpad, out);
    }
    case GST_EVENT_FLUSH_START:
      self->priv->set_flushing(true);
      return gst_pad_push_event(self->srcpad, event);
    case GST_EVENT_FLUSH_STOP:
      g_mutex_lock(&self->priv->lock);
      self->priv->requests_eos = false;
      g_mutex_unlock(&self->priv->lock);
      self->priv->set_flushing(false);
      return gst_pad_push_event(self->srcpad, event);
    case GST_EVENT_EOS:
      // Every request is answered (the request chain runs before this
      // event): the fragment stream ends, and so does the camera's.
      g_mutex_lock(&self->priv->lock);
      self->priv->requests_eos = true;
      g_cond_broadcast(&self->priv->cond);  // a camera held by kAhead goes on, to its EOS
      g_mutex_unlock(&self->priv->lock);
      return gst_pad_event_default(pad, parent, event);
    default:
      return gst_pad_event_default(pad, parent, event);
  }
}

// The camera image to warp: the frame itself, or its colour-corrected (or
// made opaque, for RGBx) copy, made once per frame.
static cv::Mat camera_image(Priv* p, State* st, GstBuffer* frame, const cv::Mat& image, bool rgbx) {
  const lf::Camera& cam = st->rig->cameras[st->index];
  if (!rgbx && !cam.has_colour_correction()) return image;
  g_mutex_lock(&p->lock);
  if (st->corrected_of != frame || st->corrected.empty()) {
    st->corrected = lf::colour_correct(cam.colour, image, lf::ChannelOrder::kRGBA, rgbx);
    st->corrected_of = frame;
  }
  cv::Mat out = st->corrected;
  g_mutex_unlock(&p->lock);
  return out;
}

static int64_t capture_time_of(LfFragment* self, GstBuffer* frame, int camera_id) {
  int meta_cam = -1;
  guint64 meta_time = 0;
  if (lfgst::read_capture_meta(frame, &meta_cam, &meta_time)) {
    if (meta_cam != camera_id)
      GST_WARNING_OBJECT(self, "frames come from camera %d, this is camera %d", meta_cam,
                         camera_id);
    return static_cast<int64_t>(meta_time);
  }
  return GST_BUFFER_PTS_IS_VALID(frame) ? static_cast<int64_t>(GST_BUFFER_PTS(frame)) : -1;
}

// With p->lock held: when a wait for a camera frame gives up (monotonic
// time, us): frame-timeout from now, or never (-1) when the camera is known
// not to be live: a non-live pipeline has no deadline, and a request there
// waits for its frame as GstAggregator waits without a latency (before, the
// wall clock dropped requests that nothing made late).
static gint64 frame_deadline(const Priv* p) {
  if (p->camera_live == 0) return -1;
  return g_get_monotonic_time() + static_cast<gint64>(p->state->s.frame_timeout / GST_USECOND);
}

// Waits on p->cond (p->lock held) until woken or `deadline` (-1: no
// deadline) for a frame captured after `want` (ns; Priv::kAnyFrame: any
// frame); false when the deadline passed. A camera held for being ahead
// goes on meanwhile, until it has made such a frame.
static bool wait_until(Priv* p, gint64 deadline, int64_t want = Priv::kAnyFrame) {
  p->want = want;
  if (p->waiting++ == 0) g_cond_broadcast(&p->cond);
  bool woken = true;
  if (deadline < 0)
    g_cond_wait(&p->cond, &p->lock);
  else
    woken = g_cond_wait_until(&p->cond, &p->lock, deadline);
  --p->waiting;
  return woken;
}

// frame-select=capture-time, with p->lock held: the frame for request time
// `t` (ns): the newest captured at or before t. Waits (at most
// frame-timeout) until that frame is known to be the one: a later frame has
// come, or one within the frame period (from the caps) before t. Then the
// newest at or before t, or when all are later (a request older than the
// ring) the oldest kept. With `exact`, only the frame of t's own tick
// (captured within a frame period before t; a camera that skipped that
// frame, being late, has none). A new reference, or nullptr.
static GstBuffer* frame_at(Priv* p, int64_t t, bool exact = false) {
  const int64_t period =
      p->have_vinfo && GST_VIDEO_INFO_FPS_N(&p->vinfo) > 0
          ? static_cast<int64_t>(gst_util_uint64_scale_int(
                GST_SECOND, GST_VIDEO_INFO_FPS_D(&p->vinfo), GST_VIDEO_INFO_FPS_N(&p->vinfo)))
          : -1;
  const gint64 deadline = frame_deadline(p);
  auto settled = [&] {
    if (p->ring.empty()) return false;
    const int64_t newest = p->ring.back().first;
    return newest > t || (period > 0 && newest > t - period);
  };
  while (!settled() && !p->flushing && !p->video_eos)
    if (!wait_until(p, deadline, period > 0 ? t - period : t)) break;
  if (p->ring.empty() || (exact && p->ring.front().first > t)) return nullptr;
  GstBuffer* best = p->ring.front().second;
  int64_t best_time = p->ring.front().first;
  for (const auto& [time, b] : p->ring)
    if (time <= t) best = b, best_time = time;
  // After the camera's end of stream its last frame stands for every later
  // instant (a still, or a camera that stopped): nothing newer will come.
  if (exact && period > 0 && best_time <= t - period && !p->video_eos) return nullptr;
  return gst_buffer_ref(best);
}

// Requests beyond the element's limits (a view larger than max-pixels, more
// than max-rate requests a second, or more than max-pixel-rate output
// pixels a second, for their viewer) are dropped with a warning: a peer
// must not make a camera host allocate or compute without bound, nor take
// another viewer's share.
static bool admit(LfFragment* self, State* st, const lf::ViewRequest& req) {
  const Settings& s = st->s;
  const guint64 px = static_cast<guint64>(req.view.width) * req.view.height;
  if (px > s.max_pixels) {
    LF_ELEMENT_WARNING_LIMITED(
        self, st->too_large, STREAM, DECODE, ("Dropping a view request larger than max-pixels"),
        "viewer %u asks for %dx%d (%" G_GUINT64_FORMAT " pixels), the limit is %" G_GUINT64_FORMAT,
        req.viewer_id, req.view.width, req.view.height, px, s.max_pixels);
    return false;
  }
  // The pixel budget shares a live host's time; a non-live pipeline renders
  // every request.
  g_mutex_lock(&self->priv->lock);
  const bool live = self->priv->camera_live != 0;
  g_mutex_unlock(&self->priv->lock);
  if (!lfgst::admit_or_warn(GST_ELEMENT(self), st->limits, st->too_fast, req.viewer_id, s.max_rate,
                            s.max_pixel_rate, static_cast<double>(px), live))
    return false;
  return true;
}

// An explicitly empty fragment of camera `cam` for `req` (wire kEmpty): a
// camera that answers without pixels of its own (capture time -1: none).
static GstBuffer* empty_fragment(const lf::ViewRequest& req, const lf::Camera& cam,
                                 int64_t capture_time_ns) {
  lf::Fragment f;
  f.viewer_id = req.viewer_id, f.sequence = req.sequence;
  f.camera_id = static_cast<uint32_t>(cam.id);
  f.capture_time_ns = capture_time_ns;
  f.out_width = req.view.width, f.out_height = req.view.height;
  const std::vector<uint8_t> bytes = lf::serialize_fragment(f, lf::Encoding::kEmpty, 90);
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
  // Wait for a camera frame (woken by a frame, end of stream, flushing or
  // PAUSED->READY): from a live camera at most frame-timeout, so one that
  // never delivers (unlinked, refused caps, dead) does not hold the request
  // thread for ever; from a non-live one as long as it takes.
  g_mutex_lock(&p->lock);
  const gint64 deadline = frame_deadline(p);
  while (p->ring.empty() && !p->flushing && !p->video_eos)
    if (!wait_until(p, deadline)) break;
  if (p->flushing) {
    g_mutex_unlock(&p->lock);
    return GST_FLOW_FLUSHING;
  }
  GstBuffer* frame = nullptr;
  // The request's time: the one it carries (the viewer's PTS, whatever the
  // network delay), else its buffer's PTS (its arrival time after RTP).
  const int64_t req_time = req.time_ns >= 0 ? req.time_ns
                           : GST_BUFFER_PTS_IS_VALID(buf)
                               ? static_cast<int64_t>(GST_BUFFER_PTS(buf))
                               : -1;
  // A probe's steps (focus or surface) must all see the frames of one
  // capture instant, in every camera: by capture time whatever frame-select
  // says, and one frame for all steps of a probe.
  const bool probe = lf::is_focus_probe(req.sequence) || lf::is_surface_probe(req.sequence);
  const uint64_t probe_key = req.sequence >> 16;
  if (probe && p->probe_frame && p->probe_key == probe_key) {
    frame = gst_buffer_ref(p->probe_frame);
  } else if ((st->s.frame_select == FrameSelect::kCaptureTime || probe) && req_time >= 0) {
    // A probe's instant already out of the ring (a camera lagging), or a
    // frame the camera skipped: this camera sits the probe out rather than
    // answer from another instant (the scene moves: cameras seeing it at
    // different instants disagree at the true depth).
    // A non-live camera has no instants to miss: it is held a frame or two
    // ahead of the requests (Priv::kAhead) and keeps two frames, so a probe
    // that follows its tick's request takes the frame nearest its time.
    frame = frame_at(p, req_time, probe && p->camera_live != 0);
    if (probe && frame) {
      p->probe_key = probe_key;
      gst_buffer_replace(&p->probe_frame, frame);
    }
  } else if (!p->ring.empty())
    frame = gst_buffer_ref(p->ring.back().second);
  if (frame) {  // a frame taken: a camera held for being ahead may make the next
    p->ahead = 0;
    g_cond_broadcast(&p->cond);
  }
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
  // defer (lfarray's whole-view mode, one request thread for all cameras):
  // a request this camera cannot answer still gets an empty answer, so
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
    if (st->s.defer) answer_empty();
    return GST_FLOW_OK;
  }
  const gint quality = lfgst::read_setting(GST_OBJECT(self), p->settings, &Settings::quality);
  GstBuffer* out = nullptr;
  const gboolean ok = lfgst::guard(
      [&] {
        const cv::Mat image(GST_VIDEO_FRAME_HEIGHT(&vf), GST_VIDEO_FRAME_WIDTH(&vf), CV_8UC4,
                            GST_VIDEO_FRAME_PLANE_DATA(&vf, 0),
                            GST_VIDEO_FRAME_PLANE_STRIDE(&vf, 0));
        const cv::Mat rgba = camera_image(p, st, frame, image,
                                          GST_VIDEO_INFO_FORMAT(&info) == GST_VIDEO_FORMAT_RGBx);
        lf::Fragment f;  // the header fields every fragment of the answer shares
        f.viewer_id = req.viewer_id;
        f.sequence = req.sequence;
        f.capture_time_ns = capture_time_of(self, frame, cam.id);
        // The camera's plans (lib/lf/session/camera_host.h): one, a layer
        // pair, or a quilt's eyes; the geometry shared with the process's
        // other cameras where it pays (a quilt's eyes each have their own).
        lf::CameraAnswer answer(
            rig, req, st->index,
            req.quilt.empty() ? lf::shared_geometry(st->rig, req, st->index, key) : nullptr);
        if (answer.quilt() && answer.sees_nothing()) {  // sees none of the eyes
          out = empty_fragment(req, cam, f.capture_time_ns);
          return;
        }
        // defer (lfarray's whole-view mode): no pixels here; the plan and
        // the image go on an empty fragment to the compositor, which draws
        // them (probes, which are scored from pixels, and layer pairs are
        // drawn here as always).
        if (st->s.defer && st->s.encoding == Encoding::kRaw && !probe && answer.count() == 1 &&
            !answer.quilt() && !answer.plan(0).empty()) {
          auto d = std::make_shared<lfgst::DeferredDraw>();
          if (rgba.data == image.data) {  // the frame itself: mapped while the drawing waits
            if (!gst_video_frame_map(&d->frame, &info, frame, GST_MAP_READ))
              throw std::runtime_error("cannot map the camera frame");
            d->mapped = true;
            d->image =
                cv::Mat(image.rows, image.cols, CV_8UC4, GST_VIDEO_FRAME_PLANE_DATA(&d->frame, 0),
                        GST_VIDEO_FRAME_PLANE_STRIDE(&d->frame, 0));
          } else {
            d->image = rgba;  // a colour-corrected copy (shared, made once per frame)
          }
          d->frame_key = frame;
          d->frame_pts = GST_BUFFER_PTS(frame);
          d->camera = cam;
          d->slot = st->index;
          d->plan = answer.take_plan(0);
          out = empty_fragment(req, cam, f.capture_time_ns);
          lfgst::add_deferred_meta(out, std::move(d));
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
          out = gst_buffer_new_allocate(nullptr, size, nullptr);
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
    if (st->s.defer) answer_empty();
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
  std::vector<lf::ViewRequest> reqs;
  std::vector<std::string> keys;  // a request's bytes, to share what it needs (geometry_for)
  GError* err = nullptr;
  {
    GstMapInfo map;
    if (!gst_buffer_map(buf, &map, GST_MAP_READ)) {
      gst_buffer_unref(buf);
      return GST_FLOW_OK;
    }
    std::vector<size_t> sizes;
    const gboolean ok =
        lfgst::guard([&] { reqs = lf::parse_requests(map.data, map.size, &sizes); }, &err);
    size_t at = 0;
    for (size_t k = 0; ok && k < reqs.size(); at += sizes[k++]) {
      keys.emplace_back();
      if (sizes[k] <= lf::kMaxSharedKeyBytes)
        keys.back().assign(reinterpret_cast<const char*>(map.data + at), sizes[k]);
    }
    gst_buffer_unmap(buf, &map);
    if (!ok) {
      LF_ELEMENT_WARNING_LIMITED(self, st->bad_request, STREAM, DECODE,
                                 ("Dropping a malformed view request"), "%s", err->message);
      g_error_free(err);
      gst_buffer_unref(buf);
      return GST_FLOW_OK;
    }
  }
  GstBuffer* bundle = nullptr;
  for (size_t k = 0; k < reqs.size(); ++k) {
    GstBuffer* out = nullptr;
    const GstFlowReturn ret = answer_request(self, reqs[k], keys[k], buf, &out);
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
  self->priv->state = std::move(st);
  self->priv->set_flushing(false);
  return TRUE;
}

static void lf_fragment_stop(LfFragment* self) {
  Priv* p = self->priv;
  g_mutex_lock(&p->lock);
  p->clear_ring();
  p->video_eos = false;
  p->requests_eos = false;
  p->camera_live = -1;
  p->ahead = p->waiting = 0;
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
  if (t == GST_STATE_CHANGE_PAUSED_TO_READY) self->priv->set_flushing(true);
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
  props.add(oc, &Settings::rig,
            g_param_spec_string("rig", "Rig", "Rig file (.json) or dataset folder", nullptr,
                                lfgst::kReadWriteReady));
  lfgst::add_camera_properties(props, oc);
  props.add(oc, &Settings::encoding,
            g_param_spec_enum("encoding", "Encoding", "Fragment payload encoding",
                              LF_TYPE_FRAGMENT_ENCODING, static_cast<gint>(DEFAULT_ENCODING),
                              lfgst::kReadWriteReady));
  props.add(oc, &Settings::quality,
            g_param_spec_int("jpeg-quality", "JPEG quality", "JPEG quality (encoding=jpeg), 1..100",
                             1, 100, DEFAULT_JPEG_QUALITY, lfgst::kReadWritePlaying));
  props.add(oc, &Settings::max_pixels,
            g_param_spec_uint64("max-pixels", "Maximum view size",
                                "Requests for views of more pixels (width x height) are dropped "
                                "with a warning",
                                1, G_MAXUINT64, DEFAULT_MAX_PIXELS, lfgst::kReadWriteReady));
  props.add(oc, &Settings::max_rate,
            g_param_spec_double("max-rate", "Maximum request rate",
                                "Requests per second answered for each viewer (bursts up to one "
                                "second's worth; one viewer's flood never spends another's); more "
                                "are dropped with a warning (0: no limit)",
                                0, 1e6, DEFAULT_MAX_RATE, lfgst::kReadWriteReady));
  props.add(oc, &Settings::max_pixel_rate,
            g_param_spec_double(
                "max-pixel-rate", "Maximum output pixel rate",
                "Live: output pixels (width x height of each request) per second answered for "
                "each viewer, so that a viewer of large views cannot take another's share of the "
                "host (bursts up to one second's worth; a request larger than one second's worth "
                "never passes); more are dropped with a warning. Default: 1920x1080 at 60 "
                "requests a second (0: no limit; not live: none, every request is rendered)",
                0, 1e12, lfgst::kDefaultMaxPixelRate, lfgst::kReadWriteReady));
  props.add(oc, &Settings::frame_timeout,
            g_param_spec_uint64("frame-timeout", "Frame timeout",
                                "How long a request waits for a camera frame (the first one; with "
                                "frame-select=capture-time or for a focus probe, the one of its "
                                "time), ns, when the camera is live; a request without a frame is "
                                "dropped with a warning (with defer, answered with an empty "
                                "fragment). A non-live camera has no deadline: the request waits "
                                "for its frame, and the camera is held two frames ahead of the "
                                "requests; the requests' end of stream ends the camera's",
                                0, G_MAXUINT64, DEFAULT_FRAME_TIMEOUT, lfgst::kReadWriteReady));
  props.add(oc, &Settings::frame_select,
            g_param_spec_enum("frame-select", "Frame selection",
                              "Which camera frame a request is rendered from",
                              LF_TYPE_FRAGMENT_FRAME_SELECT,
                              static_cast<gint>(DEFAULT_FRAME_SELECT), lfgst::kReadWriteReady));
  gst_type_mark_as_plugin_api(LF_TYPE_FRAGMENT_ENCODING, static_cast<GstPluginAPIFlags>(0));
  props.add(oc, &Settings::backend,
            g_param_spec_enum(
                "backend", "Backend",
                "Which renderer draws the fragments (lib/lf/render/gl_render.h): the CPU "
                "kernels or EGL/GLES 3; both give the same pixels within 1 LSB "
                "(identical on Mesa's llvmpipe)",
                LF_TYPE_BACKEND, static_cast<gint>(DEFAULT_BACKEND), lfgst::kReadWriteReady));
  props.add(
      oc, &Settings::defer,
      g_param_spec_boolean(
          "defer", "Defer drawing",
          "Leave the drawing to an lfcompositor in this process (lfarray's whole-view "
          "mode): each fragment goes as an empty fragment with its plan and camera image "
          "attached (LfDeferredMeta, gst/lfmeta.h), and the compositor draws all cameras "
          "of a view: with GL in one pass sequence, with no fragment read back; on the CPU "
          "band by band straight into its sums, on all cores (lib/lf/render/composite.h). The "
          "attachment never leaves the process: over RTP or to any other element these "
          "fragments are empty, so use it only with a compositor in the same process. "
          "Raw encoding only; probes and layer pairs are drawn here as always. A request "
          "without a camera frame (frame-timeout) or that cannot be planned is answered "
          "with an empty fragment (and a warning), not dropped: lfarray plans all cameras "
          "on one thread, whose pads must stay in step",
          FALSE, lfgst::kReadWriteReady));
  gst_type_mark_as_plugin_api(LF_TYPE_FRAGMENT_FRAME_SELECT, static_cast<GstPluginAPIFlags>(0));
  gst_type_mark_as_plugin_api(LF_TYPE_BACKEND, static_cast<GstPluginAPIFlags>(0));
  gst_element_class_add_static_pad_template(ec, &sink_template);
  gst_element_class_add_static_pad_template(ec, &request_template);
  gst_element_class_add_static_pad_template(ec, &src_template);
  gst_element_class_set_static_metadata(
      ec, "Light field fragment", "Filter/Video",
      "Random access camera: renders this camera's fragment of each requested view from its "
      "newest frame (Yang et al. 2002, 4.2)",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess num-buffers=60 "
      "focal-surface=false ! f.request "
      "lfcamsrc rig=../shared/data/stanford-chess row=4 col=4 ! lffragment name=f "
      "rig=../shared/data/stanford-chess row=4 col=4 ! lfcompositor ! videoconvert ! "
      "autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Warning messages, rate-limited, for each kind of request it drops: malformed, larger than "
      "max-pixels, above max-rate for its viewer, or without a camera frame within frame-timeout. "
      "An error at READY when the rig or the camera cannot be read. Nothing a peer sends ends the "
      "element.");
  ec->change_state = lf_fragment_change_state;
  GST_DEBUG_CATEGORY_INIT(lf_fragment_debug, "lffragment", 0, "light field fragments");
}
