/**
 * SECTION:element-lfcompositor
 * @title: lfcompositor
 *
 * Collects the fragments of each view request and adds them into the output
 * frame (Yang et al. 2002, Section 4.3), renormalised by the accumulated
 * weight (lib/lf/render/composite.h). An LfFragmentAggregator
 * (gst/lffragmentaggregator.h, over GstAggregator): a request is composited
 * when all of its fragments are in, or at the deadline in live pipelines
 * with whatever arrived, so a dead camera never stops the output. A partial
 * sum (`lfpartialsum`, wire version 2) counts as the cameras it holds (at
 * most the rig's). Output: raw video (RGBA, RGBx or I420; gst/lfvideoout.h).
 *
 * Every fragment is validated (lib/lf/wire/wire.h) before anything is
 * decoded: its viewer, camera, sequence window and size; the CRC check is
 * skipped only for buffers `lffragment` sealed in this process
 * (`LfSealedMeta`, which no copy and nothing from the network has). Raw
 * fragments are added straight from the received buffers; JPEG ones are
 * decoded on the streaming thread that brings them (gst/lfarrival.h).
 * Drawings that `lffragment defer=true` left to it (lfarray's whole-view
 * mode, `LfDeferredMeta`) are drawn here by its renderer
 * (lib/lf/render/renderer.h: GL uploads each camera frame once; the CPU
 * fuses the drawing into the compositing, bands of rows on all cores).
 *
 * The output rate is the fragment caps' `framerate` (the viewer's request
 * rate; the `framerate` property overrides it); the deadline is one frame
 * period after a request's running time (gst_aggregator_set_latency),
 * unless the `latency` property is set, which then replaces it.
 *
 * Probes are scored here, never composited (lib/lf/session/probe_scoring.h):
 * a focus probe gives the depth under a clicked pixel (an upstream
 * `lf-focus` event), a surface probe a focal surface for the whole view (an
 * upstream `lf-surface` event; see `lfviewrequest`'s focal-surface). This is
 * the one place where every camera's contribution arrives separately, so it
 * works unchanged across machines: no camera image leaves its host.
 *
 * With `second-planes`, tiles next to a depth edge or with a thin structure
 * inside get a second plane (lib/lf/focus/focal_surface.h); a camera then
 * answers with its layer 0 and layer 1 in one buffer, and the frame takes per
 * pixel the layer whose cameras agree (lf::LayerCompositor, on the CPU
 * whatever the backend). A buffer whose second fragment is not the same
 * camera's layer 1 of the same request is dropped with a warning.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 lfviewrequest rig=rig.json num-buffers=30 ! tee name=t \
 *   t. ! queue ! f0.request lfcamsrc rig=rig.json camera-id=0 ! f0.sink \
 *   lffragment name=f0 rig=rig.json camera-id=0 ! c.sink_0 \
 *   t. ! queue ! f1.request lfcamsrc rig=rig.json camera-id=1 ! f1.sink \
 *   lffragment name=f1 rig=rig.json camera-id=1 ! c.sink_1 \
 *   lfcompositor name=c rig=rig.json ! videoconvert ! autovideosink
 * ]|
 */
#include <gst/base/gstaggregator.h>
#include <gst/video/video.h>
#include <libdeflate.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <optional>

#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/render/fragment.h"
#include "lf/render/renderer.h"
#include "lf/session/compositor_host.h"
#include "lf/session/frame_assembly.h"
#include "lf/session/probe_scoring.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"
#include "lfaggregate.h"
#include "lfarrival.h"
#include "lfbackend.h"
#include "lfcaps.h"
#include "lfevents.h"
#include "lffragmentaggregator.h"
#include "lfguard.h"
#include "lfmeta.h"
#include "lfprops.h"
#include "lfrig.h"
#include "lftrace.h"
#include "lfvideoout.h"
#include "lfwarn.h"

GST_DEBUG_CATEGORY_STATIC(lf_compositor_debug);
#define GST_CAT_DEFAULT lf_compositor_debug

G_BEGIN_DECLS
#define LF_TYPE_COMPOSITOR (lf_compositor_get_type())
G_DECLARE_FINAL_TYPE(LfCompositor, lf_compositor, LF, COMPOSITOR, LfFragmentAggregator)
G_END_DECLS

#define DEFAULT_VIEWER_ID 0
#define DEFAULT_WIDTH 0  // 0: from the fragment caps (the viewer's request size)
#define DEFAULT_HEIGHT 0
#define DEFAULT_FPS_N 0  // 0/1: from the fragment caps
#define DEFAULT_FPS_D 1
#define DEFAULT_STEREO FALSE
// Output rate when neither the caps nor the property give one.
#define FALLBACK_FPS_N 30
#define FALLBACK_FPS_D 1
// Largest output frame (its accumulators take 16 bytes a pixel).
#define MAX_OUTPUT_SIDE 8192

namespace {
struct Settings {
  std::string rig;
  gint viewer_id = DEFAULT_VIEWER_ID;
  gint width = DEFAULT_WIDTH, height = DEFAULT_HEIGHT;
  lfgst::Fraction framerate{DEFAULT_FPS_N, DEFAULT_FPS_D};
  bool stereo = DEFAULT_STEREO;
  bool second_planes = false;  // surface probes: second planes at depth edges and thin structures
  lf::Backend backend = lf::Backend::kAuto;
  // Read-only statistics, written by the aggregate thread under the lock.
  guint64 frames = 0;      // frames composited since start
  guint last_cameras = 0;  // cameras (per eye) whose fragment was in the last frame
};
// A fragment waiting for its frame (lf::ReceivedPiece): raw fragments are
// parsed in place, their pixels in the received buffer, which stays mapped
// (and referenced) until the frame is composited; JPEG ones are decoded
// into `f.pixels`. A buffer holding a camera's two layers, or its fragments
// of a quilt's eyes (lib/lf/wire/wire.h), gives a piece each, sharing the
// mapping.
using Piece = lf::ReceivedPiece;
// A request waiting for its fragments (lib/lf/session/frame_assembly.h): a
// buffer's pieces are filed under its camera (viewer << 32 | camera).
using Request = lf::PendingRequest<Piece>;
// The request window (lf::RequestWindow: RFC 3550 appendix A.1, so no
// single forged or stray packet moves it) and at most this many requests
// waiting.
constexpr size_t kMaxPending = 16;
// A focus probe is scored when every camera answered every step, or this long
// (at least; the compositor's latency when longer) after its first fragment
// with what came (a dead camera).
constexpr gint64 kProbeDeadlineUs = G_USEC_PER_SEC;
// From start (READY->PAUSED) to stop (PAUSED->READY); used on the aggregate
// thread only (GstAggregator handles serialized sink events there too).
struct State {
  Settings s;  // snapshot taken at start
  std::shared_ptr<const lf::Rig> rig;
  lf::PendingRequests<uint64_t, Piece> pending{kMaxPending};  // by request sequence
  lf::RequestWindow window;
  guint64 conflicts = 0;       // fragments dropped as a second copy of a camera's in a request
  lf::ViewerSelection viewer;  // the viewer composited (viewer-id, or the first seen)
  // The frames, made by the renderer (lib/lf/render/renderer.h: the CPU
  // kernels, or GL) chosen at start by `backend`; its image slots hold the
  // camera frames of drawings left to us (each uploaded once with GL).
  std::optional<lf::FrameCompositor> frames;
  lfgst::RawVideoOutput output;          // the negotiated raw video (gst/lfvideoout.h)
  lfgst::Fraction caps_fps{0, 1};        // from the fragment caps (0/1: none yet)
  gint caps_width = 0, caps_height = 0;  // the view size from the fragment caps
  guint64 filled_frames = 0;
  std::optional<lf::ProbeScoring> probes;  // focus and surface probes being collected
  lfgst::WarnLimiter no_focus, no_surface, bad, foreign, unknown_camera, wrong_size, no_size,
      out_of_window, duplicate;
  // The output rate: the property, else the caps, else 30/1.
  lfgst::Fraction fps() const {
    if (s.framerate.n > 0) return s.framerate;
    if (caps_fps.n > 0) return caps_fps;
    return {FALLBACK_FPS_N, FALLBACK_FPS_D};
  }
  // The size of one view (the output is twice as wide in stereo): the
  // properties, else the caps; never what a fragment claims. False if unknown.
  bool view_size(int* w, int* h) const {
    *w = s.width > 0 ? s.width : caps_width;
    *h = s.height > 0 ? s.height : caps_height;
    return *w > 0 && *h > 0;
  }
};

struct Priv {
  Settings settings;  // properties (object lock)
  std::unique_ptr<State> state;
  // One frame period of the output rate (ns; 0 until the caps give a rate):
  // read by the `latency` notify handler on any thread, so not in State.
  std::atomic<GstClockTime> period{0};
  // JPEG fragments decoded as they arrive, on the pads' streaming threads,
  // as far as the aggregate thread accepts them (publish_acceptance()).
  lfgst::ArrivalDecoder arrival;
};

lfgst::Properties<Settings> props;
}  // namespace

struct _LfCompositor {
  LfFragmentAggregator parent;
  Priv* priv;
};

G_DEFINE_TYPE(LfCompositor, lf_compositor, LF_TYPE_FRAGMENT_AGGREGATOR)
GST_ELEMENT_REGISTER_DEFINE(lfcompositor, "lfcompositor", GST_RANK_NONE, LF_TYPE_COMPOSITOR)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink_%u", GST_PAD_SINK, GST_PAD_REQUEST, GST_STATIC_CAPS(LF_FRAGMENT_CAPS));
static GstStaticPadTemplate src_template = GST_STATIC_PAD_TEMPLATE(
    "src", GST_PAD_SRC, GST_PAD_ALWAYS,
    GST_STATIC_CAPS("video/x-raw, format = (string) { RGBA, RGBx, I420 }, width = (int) [ 2, "
                    "16384 ], height = (int) [ 2, 16384 ], framerate = (fraction) [ 0/1, MAX ]"));

static void lf_compositor_property_set(GObject*, GParamSpec*, const GValue*) {}
LF_DEFINE_ELEMENT_GLUE(lf_compositor, LF_COMPOSITOR)

static gboolean lf_compositor_start(GstAggregator* agg) {
  LfCompositor* self = LF_COMPOSITOR(agg);
  auto st = std::make_unique<State>();
  GST_OBJECT_LOCK(self);
  self->priv->settings.frames = 0, self->priv->settings.last_cameras = 0;
  GST_OBJECT_UNLOCK(self);
  st->s = lfgst::snapshot(GST_OBJECT(self), self->priv->settings);
  if (!st->s.rig.empty()) {
    st->rig = lfgst::open_rig(GST_ELEMENT(self), st->s.rig);
    if (!st->rig) return FALSE;
  }
  st->viewer = lf::ViewerSelection(st->s.viewer_id);
  st->probes.emplace(st->rig);
  std::unique_ptr<lf::Renderer> renderer;
  if (!lfgst::open_renderer(GST_ELEMENT(self), st->s.backend, renderer)) return FALSE;
  st->frames.emplace(std::move(renderer));
  self->priv->state = std::move(st);
  return TRUE;
}

static gboolean lf_compositor_stop(GstAggregator* agg) {
  LF_COMPOSITOR(agg)->priv->state.reset();
  LF_COMPOSITOR(agg)->priv->arrival.stop();
  return TRUE;
}

// Publishes what absorb() accepts now (aggregate thread), for
// decode_on_arrival().
static void publish_acceptance(Priv* p, const State* st) {
  int w = 0, h = 0;
  p->arrival.publish(st->view_size(&w, &h) ? static_cast<uint64_t>(w) * h : 0, st->viewer.viewer(),
                     st->s.stereo, st->window.last_emitted());
}

// The deadline: one frame period of the request rate, unless the `latency`
// property is set (then it alone).
static void update_latency(LfCompositor* self) {
  const GstClockTime period = self->priv->period.load();
  if (period == 0) return;
  GstClockTime user = 0;
  g_object_get(self, "latency", &user, nullptr);
  const GstClockTime own = user > 0 ? 0 : period;
  gst_aggregator_set_latency(GST_AGGREGATOR(self), own, own);
}

static gboolean lf_compositor_sink_event(GstAggregator* agg, GstAggregatorPad* pad,
                                         GstEvent* event) {
  LfCompositor* self = LF_COMPOSITOR(agg);
  State* st = self->priv->state.get();
  if (GST_EVENT_TYPE(event) == GST_EVENT_CAPS && st) {
    GstCaps* caps;
    gst_event_parse_caps(event, &caps);
    const GstStructure* cs = gst_caps_get_structure(caps, 0);
    gint w = 0, h = 0;
    if (gst_structure_get_int(cs, "width", &w) && gst_structure_get_int(cs, "height", &h)) {
      if (w < 1 || h < 1 || w > MAX_OUTPUT_SIDE || h > MAX_OUTPUT_SIDE) {
        GST_ELEMENT_WARNING(self, STREAM, FORMAT, ("Ignoring a view size out of range"),
                            ("fragment caps announce %dx%d (1..%d)", w, h, MAX_OUTPUT_SIDE));
      } else if (st->s.width <= 0 || st->s.height <= 0) {
        if (st->caps_width > 0 && (w != st->caps_width || h != st->caps_height))
          GST_WARNING_OBJECT(self, "fragment caps change the view size from %dx%d to %dx%d",
                             st->caps_width, st->caps_height, w, h);
        st->caps_width = w, st->caps_height = h;
      }
    }
    gint n, d;
    if (lfgst::caps_framerate(caps, &n, &d) && !(lfgst::Fraction{n, d} == st->caps_fps)) {
      if (st->caps_fps.n > 0)
        GST_WARNING_OBJECT(self, "fragment caps change the request rate from %d/%d to %d/%d",
                           st->caps_fps.n, st->caps_fps.d, n, d);
      st->caps_fps = {n, d};
      const lfgst::Fraction fps = st->fps();
      self->priv->period = gst_util_uint64_scale_int(GST_SECOND, fps.d, fps.n);
      update_latency(self);
    }
  }
  return GST_AGGREGATOR_CLASS(lf_compositor_parent_class)->sink_event(agg, pad, event);
}

// Number of fragments a complete request has: the rig's cameras, or else one
// per sink pad (twice that in stereo).
static size_t expected_fragments(LfCompositor* self) {
  State* st = self->priv->state.get();
  if (st->rig) return st->rig->cameras.size() * (st->s.stereo ? 2 : 1);
  GST_OBJECT_LOCK(self);
  const size_t n = GST_ELEMENT(self)->numsinkpads;
  GST_OBJECT_UNLOCK(self);
  return n * (st->s.stereo ? 2 : 1);  // stereo: a left and a right fragment per pad
}

// GstAggregator's own negotiation (at start, and when downstream asks for a
// reconfiguration) would fix caps before the view size is known: the template
// fixates to 2x2 at 0/1 fps, and an encoder such as vp8enc, configured for
// that, then drops every frame. The output is negotiated by emit() at
// the next frame instead (aggregate thread, like aggregate()).
static gboolean lf_compositor_negotiate(GstAggregator* agg) {
  if (State* st = LF_COMPOSITOR(agg)->priv->state.get()) st->output.renegotiate();
  return TRUE;
}

static GstFlowReturn emit(LfCompositor* self, uint64_t seq, Request& g, bool complete) {
  State* st = self->priv->state.get();
  const gint64 t0 = g_get_monotonic_time();
  int w = 0, H = 0;
  if (!st->view_size(&w, &H)) return GST_FLOW_OK;  // nothing was accepted without a size
  const int W = st->s.stereo ? 2 * w : w;          // stereo: left | right side by side
  if (!st->output.negotiate(GST_AGGREGATOR(self), W, H, st->fps())) return GST_FLOW_NOT_NEGOTIATED;
  const guint left_id = static_cast<guint>(std::max<int64_t>(0, st->viewer.viewer()));
  // Each eye's fragments and the drawings lffragment left to us (defer:
  // whole-view mode), composited at once (lib/lf/session/compositor_host.h).
  lf::FrameCompositor::Result r;
  GError* err = nullptr;
  if (!lfgst::guard(
          [&] { r = st->frames->composite(g.pieces, w, H, st->s.stereo, left_id, complete); },
          &err)) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Cannot composite the frame"), ("%s", err->message));
    g_error_free(err);
    return GST_FLOW_ERROR;
  }
  for (const auto& [camera, why] : r.refused)
    GST_WARNING_OBJECT(self, "dropping fragment of camera %d: %s", camera, why.c_str());
  const size_t filled = r.filled;  // a missed deadline: pixels from the last frame
  if (filled) {
    st->filled_frames++;
    GST_DEBUG_OBJECT(self, "request %" G_GUINT64_FORMAT ": %zu pixels from the last frame", seq,
                     filled);
  }
  const cv::Mat& rgba = *r.frame;
  GstBuffer* out = st->output.frame(rgba);
  if (lfgst::trace_enabled()) {
    const uint32_t sum = libdeflate_crc32(0, rgba.data, rgba.total() * rgba.elemSize());
    lfgst::trace(GST_ELEMENT(self), "composited", left_id, seq, -1, static_cast<gint64>(g.count),
                 static_cast<gint64>(sum), (g_get_monotonic_time() - t0) * 1000);
    if (filled)
      lfgst::trace(GST_ELEMENT(self), "filled", left_id, seq, -1, static_cast<gint64>(filled));
  }
  GST_BUFFER_PTS(out) = g.pts;
  GST_BUFFER_DURATION(out) = g.duration;
  GST_BUFFER_OFFSET(out) = seq;
  st->window.emitted(seq);
  // Before the frame goes out: whoever sees it and sends on can rely on
  // the new window (decode_on_arrival).
  publish_acceptance(self->priv, st);
  GST_OBJECT_LOCK(self);
  self->priv->settings.frames++;
  self->priv->settings.last_cameras = static_cast<guint>(g.count);
  GST_OBJECT_UNLOCK(self);
  GstAggregator* agg = GST_AGGREGATOR(self);
  if (GST_CLOCK_TIME_IS_VALID(g.pts)) {
    GstSegment* seg = &GST_AGGREGATOR_PAD(agg->srcpad)->segment;
    seg->position = g.pts + (GST_CLOCK_TIME_IS_VALID(g.duration) ? g.duration : 0);
  }
  GST_LOG_OBJECT(self, "request %" G_GUINT64_FORMAT ": %zu fragments", seq, g.pieces.size());
  return gst_aggregator_finish_buffer(agg, out);
}

// Whether a fragment's sequence is one to composite: inside the window after
// the last frame emitted, or confirmed on probation (lf::RequestWindow).
static bool sequence_accepted(LfCompositor* self, State* st, uint64_t seq) {
  const int64_t cand = st->window.candidate();
  switch (st->window.offer(seq)) {
    case lf::RequestWindow::Verdict::kAccept:
      return true;
    case lf::RequestWindow::Verdict::kFollow:
      LF_ELEMENT_WARNING_LIMITED(self, st->out_of_window, STREAM, DECODE,
                                 ("Following a new request sequence"),
                                 "fragments of requests %" G_GINT64_FORMAT " and %" G_GUINT64_FORMAT
                                 " arrive, outside the window (a restarted viewer, or requests "
                                 "lost for a while)",
                                 cand, seq);
      st->pending.clear();
      return true;
    default:
      return false;
  }
}

// A fragment of another viewer: after a while of only those
// (lf::ViewerSelection), warn once that viewer-id names a viewer that is
// not there (a misconfiguration that would otherwise produce nothing,
// silently).
static void note_foreign(LfCompositor* self, State* st, guint viewer) {
  const gint64 now = g_get_monotonic_time();
  if (!st->viewer.foreign(now)) return;
  GST_ELEMENT_WARNING(self, STREAM, WRONG_TYPE,
                      ("No fragments of viewer %" G_GINT64_FORMAT, st->viewer.viewer()),
                      ("%" G_GUINT64_FORMAT " fragments in %.1f s, all of other viewers (such "
                       "as %u): check viewer-id (lfviewrequest viewer-id, or -1 here to "
                       "take the first viewer seen)",
                       st->viewer.foreign_count(), st->viewer.foreign_seconds(now), viewer));
}

// Sends what probe scoring (lib/lf/session/probe_scoring.h) gave upstream:
// an lf-focus event (the depth under a clicked pixel) or an lf-surface
// event (gst/lfevents.h), which lfviewrequest applies; or a warning.
static void send_probe_outcomes(LfCompositor* self, State* st) {
  for (lf::ProbeOutcome& o : st->probes->take()) {
    const bool focus = o.kind == lf::ProbeOutcome::Kind::kFocus;
    if (o.result == lf::ProbeOutcome::Result::kSatOut) {
      GST_INFO_OBJECT(self, "surface probe %u: every camera sat it out (%d cameras)", o.probe,
                      o.cameras);
      continue;
    }
    if (o.result == lf::ProbeOutcome::Result::kFailed) {
      if (focus)
        LF_ELEMENT_WARNING_LIMITED(
            self, st->no_focus, STREAM, FAILED, ("Cannot focus at the clicked point"),
            "probe %u: %s (%zu fragments)", o.probe, o.why.c_str(), o.fragments);
      else
        LF_ELEMENT_WARNING_LIMITED(self, st->no_surface, STREAM, FAILED,
                                   ("Cannot estimate the focal surface"),
                                   "surface probe %u: %s (%zu fragments from %d cameras)", o.probe,
                                   o.why.c_str(), o.fragments, o.cameras);
      continue;
    }
    GstStructure* s;
    if (focus) {
      lfgst::trace(GST_ELEMENT(self), "focused", o.viewer, o.probe, -1,
                   static_cast<gint64>(o.inverse_depth * 1e9));
      GST_DEBUG_OBJECT(self, "focus probe %u: inverse depth %g from %d cameras (%zu fragments)",
                       o.probe, o.inverse_depth, o.cameras, o.fragments);
      s = lfgst::focus_structure({o.viewer, o.probe, o.inverse_depth, o.capture_time_ns});
    } else {
      lfgst::trace(GST_ELEMENT(self), "surface", o.viewer, o.probe, -1, o.planes_used);
      GST_DEBUG_OBJECT(self,
                       "surface probe %u: %d planes (%zu of %zu tiles textured) from %d cameras "
                       "(%zu fragments), estimated in %.1f ms",
                       o.probe, o.planes_used, o.textured, o.tiles, o.cameras, o.fragments,
                       o.estimate_ms);
      s = lfgst::surface_structure(
          {o.viewer, o.probe, o.capture_time_ns, std::move(o.surface), o.planes_used});
    }
    lf_fragment_aggregator_push_upstream(LF_FRAGMENT_AGGREGATOR(self),
                                         gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, s));
  }
}

// A probe's answer from one camera (header already checked: our viewer, a
// known camera), scored, never composited (lf::ProbeScoring).
static void absorb_probe_answer(LfCompositor* self, State* st, const guint8* data, gsize size,
                                int w, int h) {
  lf::SurfaceOptions opt;
  opt.second_planes =
      lfgst::read_setting(GST_OBJECT(self), self->priv->settings, &Settings::second_planes);
  GError* err = nullptr;
  if (!lfgst::guard([&] { st->probes->absorb(data, size, w, h, opt, g_get_monotonic_time()); },
                    &err)) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE, ("Dropping a malformed fragment"),
                               "%s", err->message);
    g_error_free(err);
  }
  send_probe_outcomes(self, st);
}

// Parses one fragment buffer and files it under its request. What a peer
// sends is checked from the header before anything is decoded: the viewer,
// the camera, the sequence window and the output size; then the payload is
// parsed with the frame's area as its pixel limit.
static void absorb(LfCompositor* self, GstAggregatorPad* pad, GstBuffer* buf) {
  State* st = self->priv->state.get();
  GError* err = nullptr;
  std::optional<lfgst::MappedBuffer> mapped;
  if (!lfgst::guard([&] { mapped.emplace(buf, GST_MAP_READ); }, &err)) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE, ("Dropping a malformed fragment"),
                               "%s", err->message);
    g_error_free(err);
    return;
  }
  const uint8_t* data = mapped->data();
  const size_t size = mapped->size();
  lf::FragmentHeader head;
  // The camera's answer: one fragment, its layer pair, or its quilt eyes
  // (lf::parse_frame_answer).
  std::vector<lf::AnswerPiece> parts;
  int w = 0, h = 0;
  const gint64 t0 = g_get_monotonic_time();
  if (!lfgst::guard([&] { head = lf::peek_fragment_header(data, size); }, &err)) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE, ("Dropping a malformed fragment"),
                               "%s", err->message);
    g_error_free(err);
  } else if (!st->viewer.accepts(head.viewer_id, st->s.stereo)) {
    GST_LOG_OBJECT(self, "fragment of viewer %u: not ours", head.viewer_id);
    note_foreign(self, st, head.viewer_id);
  } else if (st->rig && st->rig->index_of(static_cast<int>(head.camera_id)) < 0) {
    LF_ELEMENT_WARNING_LIMITED(self, st->unknown_camera, STREAM, DECODE,
                               ("Dropping a fragment of an unknown camera"),
                               "camera %u is not in the rig", head.camera_id);
  } else if (lf::is_focus_probe(head.sequence) ||
             (lf::is_surface_probe(head.sequence) && st->view_size(&w, &h))) {
    absorb_probe_answer(self, st, data, size, w, h);
  } else if (!st->view_size(&w, &h)) {
    LF_ELEMENT_WARNING_LIMITED(self, st->no_size, STREAM, FORMAT,
                               ("No output size: dropping fragments"),
                               "set width and height, or send fragment caps with the view's "
                               "width and height (lfviewrequest does) (camera %u)",
                               head.camera_id);
  } else if (!sequence_accepted(self, st, head.sequence)) {
    GST_LOG_OBJECT(self, "fragment of request %" G_GUINT64_FORMAT ": outside the window",
                   head.sequence);
  } else if (!lfgst::guard(
                 [&] {
                   // All of them together carry at most the frame's pixels.
                   parts = lf::parse_frame_answer(data, size, static_cast<size_t>(w) * h,
                                                  !lfgst::has_sealed_meta(buf));
                 },
                 &err)) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE, ("Dropping a malformed fragment"),
                               "%s", err->message);
    g_error_free(err);
  } else if (const lf::Fragment& f = parts.front().f;
             f.cameras > 1 && st->rig && f.cameras > st->rig->cameras.size()) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE, ("Dropping a malformed fragment"),
                               "camera %u: a partial sum of %u cameras, the rig has %zu",
                               f.camera_id, f.cameras, st->rig->cameras.size());
  } else if (std::any_of(parts.begin(), parts.end(), [&](const lf::AnswerPiece& a) {
               return a.f.out_width != w || a.f.out_height != h;
             })) {
    LF_ELEMENT_WARNING_LIMITED(self, st->wrong_size, STREAM, DECODE,
                               ("Dropping a fragment for another output size"),
                               "camera %u: fragment for %dx%d, the output is %dx%d", f.camera_id,
                               f.out_width, f.out_height, w, h);
  } else {
    gint64 on_arrival_ns = 0;
    lfgst::ArrivalDecoder::decoded(buf, &on_arrival_ns);
    lfgst::trace(GST_ELEMENT(self), "decoded", f.viewer_id, f.sequence,
                 static_cast<gint>(f.camera_id),
                 (g_get_monotonic_time() - t0) * 1000 + on_arrival_ns);
    if (st->viewer.taken(f.viewer_id))  // viewer-id -1: the first viewer seen, then only it
      GST_INFO_OBJECT(self, "compositing viewer %u", f.viewer_id);
    const uint64_t seq = f.sequence;
    const uint64_t source = (static_cast<uint64_t>(f.viewer_id) << 32) | f.camera_id;
    const size_t cameras = f.cameras;
    const uint32_t camera = f.camera_id;
    const bool any_raw = std::any_of(parts.begin(), parts.end(), [](const lf::AnswerPiece& a) {
      return a.encoding == lf::Encoding::kRaw;
    });
    std::vector<Piece> pieces;
    for (lf::AnswerPiece& a : parts)
      pieces.push_back({std::move(a.f), a.encoding == lf::Encoding::kRaw ? a.pixels : nullptr});
    Piece& piece = pieces.front();
    // A drawing left to us: only on an empty fragment this process made
    // (the meta is never copied), for this camera and this view size.
    if (piece.f.empty() && pieces.size() == 1)
      if (auto d = lfgst::deferred_of(buf); d &&
                                            d->camera.id == static_cast<int>(piece.f.camera_id) &&
                                            d->plan.out_width == w && d->plan.out_height == h)
        piece.deferred = std::move(d);
    if (any_raw) {
      const std::shared_ptr<const void> keep =
          std::make_shared<const lfgst::MappedBuffer>(std::move(*mapped));
      for (Piece& p : pieces) p.keep = keep;
    }
    const GstClockTime pts = GST_BUFFER_PTS(buf);
    const GstClockTime rt = GST_CLOCK_TIME_IS_VALID(pts)
                                ? gst_segment_to_running_time(&pad->segment, GST_FORMAT_TIME, pts)
                                : GST_CLOCK_TIME_NONE;
    if (st->pending.add(seq, source, cameras, std::move(pieces), rt, pts,
                        GST_BUFFER_DURATION(buf)) ==
        lf::PendingRequests<uint64_t, Piece>::Added::kDuplicate) {
      // A second fragment of this camera for this request: one of the two is
      // forged (plain RTP) or a stray copy, and nothing tells which. Neither
      // is used, so a forgery can cost a camera's part of one frame (filled
      // by the others) but never put its pixels in it.
      st->pending.discard(seq, source);
      st->conflicts++;
      LF_ELEMENT_WARNING_LIMITED(
          self, st->duplicate, STREAM, DECODE, ("Dropping both copies of a fragment"),
          "camera %u sent two fragments for request %" G_GUINT64_FORMAT " (%" G_GUINT64_FORMAT
          " so far): one is forged or a stray copy, so neither is used "
          "(on an untrusted network authenticate the streams: SRTP_KEY)",
          camera, seq, st->conflicts);
    }
  }
}

// `stereo` may change while playing: the requests from here on follow it.
static void lf_compositor_begin(LfFragmentAggregator* agg) {
  LfCompositor* self = LF_COMPOSITOR(agg);
  self->priv->state->s.stereo =
      lfgst::read_setting(GST_OBJECT(self), self->priv->settings, &Settings::stereo);
}

// lffragmentaggregator.h: a fragment buffer taken from a pad.
static GstFlowReturn lf_compositor_absorb(LfFragmentAggregator* agg, GstAggregatorPad* pad,
                                          GstBuffer* buf) {
  absorb(LF_COMPOSITOR(agg), pad, buf);
  return GST_FLOW_OK;
}

// Live: at most one request's worth of fragments per pad per aggregate().
static gsize lf_compositor_live_batch(LfFragmentAggregator* agg) {
  return expected_fragments(LF_COMPOSITOR(agg));
}

static const lf::RequestTimes* lf_compositor_requests(LfFragmentAggregator* agg) {
  const State* st = LF_COMPOSITOR(agg)->priv->state.get();
  return st ? &st->pending : nullptr;
}

// Probes past their deadline are scored with what came; then complete
// requests, in order; at its deadline (or end of stream), also an
// incomplete one, renormalised; too many pending: the oldest. Each request
// has its own deadline: one that came late must not take the next ones,
// still in time, with it (their fragments are on their way).
static GstFlowReturn lf_compositor_emit_due(LfFragmentAggregator* agg, const LfDeadline* d,
                                            gboolean all_eos) {
  LfCompositor* self = LF_COMPOSITOR(agg);
  State* st = self->priv->state.get();
  const gint64 probe_deadline_us =
      d->live ? std::max<gint64>(kProbeDeadlineUs, static_cast<gint64>(d->latency / GST_USECOND))
              : kProbeDeadlineUs;
  st->probes->expire(g_get_monotonic_time(), probe_deadline_us);
  send_probe_outcomes(self, st);
  const size_t expected = expected_fragments(self);
  const GstFlowReturn ret = lfgst::emit_due(
      st->pending, expected, [d](GstClockTime rt) { return lf_deadline_passed(d, rt); }, all_eos,
      [&](uint64_t seq, Request& g, bool complete) {
        if (!complete)
          GST_DEBUG_OBJECT(self,
                           "request %" G_GUINT64_FORMAT
                           " incomplete: %zu of %zu fragments (eos %d, pending %zu)",
                           seq, g.count, expected, all_eos, st->pending.size());
        return emit(self, seq, g, complete);
      });
  publish_acceptance(self->priv, st);
  return ret;
}

static GstPad* lf_compositor_request_new_pad(GstElement* el, GstPadTemplate* templ,
                                             const gchar* name, const GstCaps* caps) {
  GstPad* pad =
      GST_ELEMENT_CLASS(lf_compositor_parent_class)->request_new_pad(el, templ, name, caps);
  if (!pad) return pad;
  LF_COMPOSITOR(el)->priv->arrival.install(pad);
  return pad;
}

// Navigation and lf-view events from downstream (they go up every sink pad,
// lffragmentaggregator.h) are tagged with this compositor's viewer-id
// (unless they name one), so only this viewer is steered.
static GstEvent* lf_compositor_tag_upstream(LfFragmentAggregator* agg, GstEvent* event) {
  const gint viewer = lfgst::read_setting(GST_OBJECT(agg), LF_COMPOSITOR(agg)->priv->settings,
                                          &Settings::viewer_id);
  if (viewer >= 0 && !gst_structure_has_field(gst_event_get_structure(event), "viewer-id")) {
    event = gst_event_make_writable(event);
    gst_structure_set(gst_event_writable_structure(event), "viewer-id", G_TYPE_UINT,
                      static_cast<guint>(viewer), nullptr);
  }
  return event;
}

static void on_latency_changed(GObject* obj, GParamSpec*, gpointer) {
  update_latency(LF_COMPOSITOR(obj));
}

static void lf_compositor_init(LfCompositor* self) {
  self->priv = new Priv();
  g_signal_connect(self, "notify::latency", G_CALLBACK(on_latency_changed), nullptr);
}

static void lf_compositor_class_init(LfCompositorClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  GstAggregatorClass* ac = GST_AGGREGATOR_CLASS(klass);
  oc->set_property = lf_compositor_set_property;
  oc->get_property = lf_compositor_get_property;
  oc->finalize = lf_compositor_finalize;
  const GParamFlags rw = lfgst::kReadWriteReady;
  props.add(oc, &Settings::rig,
            g_param_spec_string("rig", "Rig",
                                "Rig file or dataset folder: a request is complete when every "
                                "camera of the rig has answered (unset: one fragment per sink "
                                "pad)",
                                nullptr, rw));
  props.add(
      oc, &Settings::viewer_id,
      g_param_spec_int("viewer-id", "Viewer id", "Composite only this viewer's requests (-1: any)",
                       -1, G_MAXINT, DEFAULT_VIEWER_ID, rw));
  props.add(oc, &Settings::width,
            g_param_spec_int("width", "Width",
                             "Width of one view, pixels (0: from the fragment caps, the viewer's "
                             "request size). Set it where fragments arrive from a network: caps "
                             "travel in band and any sender can announce them",
                             0, MAX_OUTPUT_SIDE, DEFAULT_WIDTH, rw));
  props.add(
      oc, &Settings::height,
      g_param_spec_int("height", "Height", "Height of one view, pixels (0: from the fragment caps)",
                       0, MAX_OUTPUT_SIDE, DEFAULT_HEIGHT, rw));
  props.add(oc, &Settings::framerate,
            gst_param_spec_fraction("framerate", "Frame rate",
                                    "Output frame rate; 0/1: the request rate from the fragment "
                                    "caps (30/1 if they carry none)",
                                    0, 1, 1000, 1, DEFAULT_FPS_N, DEFAULT_FPS_D, rw));
  props.add(oc, &Settings::stereo,
            g_param_spec_boolean("stereo", "Stereo",
                                 "Composite the requests of viewer-id (left) and viewer-id + 1 "
                                 "(right) side by side (lfviewrequest stereo-baseline), output "
                                 "twice as wide; changeable while playing (the output is then "
                                 "renegotiated)",
                                 DEFAULT_STEREO, lfgst::kReadWritePlaying));
  props.add(
      oc, &Settings::second_planes,
      g_param_spec_boolean(
          "second-planes", "Second planes",
          "Surface probes (lfviewrequest focal-surface): tiles next to a depth edge get the "
          "neighbouring depth as a second plane, tiles with a thin structure inside (bars, "
          "wires) its depth; the cameras then send those tiles twice "
          "(layer 1: the nearer plane) and this element takes per pixel the layer whose "
          "cameras agree (lib/lf/render/composite.h LayerCompositor, on the CPU); more bytes where "
          "the scene has depth edges, none elsewhere",
          FALSE, lfgst::kReadWritePlaying));
  props.add(
      oc, &Settings::backend,
      g_param_spec_enum("backend", "Backend",
                        "Which renderer adds the fragments and resolves the frame "
                        "(lib/lf/render/gl_render.h): the CPU (bands of rows on every core) or "
                        "EGL/GLES 3 (blending); the same frame within 1 LSB (identical on "
                        "Mesa's llvmpipe)",
                        lfgst::backend_type(), static_cast<gint>(lf::Backend::kAuto),
                        lfgst::kReadWriteReady));
  const GParamFlags ro = static_cast<GParamFlags>(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS);
  props.add(oc, &Settings::frames,
            g_param_spec_uint64("frames", "Frames", "Frames composited since the element started",
                                0, G_MAXUINT64, 0, ro));
  props.add(oc, &Settings::last_cameras,
            g_param_spec_uint("last-cameras", "Cameras in the last frame",
                              "Cameras whose fragment was in the last composited frame (both "
                              "eyes counted in stereo); fewer than the rig's: the deadline "
                              "passed without them",
                              0, G_MAXUINT, 0, ro));
  gst_element_class_add_static_pad_template_with_gtype(ec, &sink_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype(ec, &src_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_set_static_metadata(
      ec, "Light field compositor", "Filter/Editor/Video/Compositor",
      "Adds the image fragments of each view request into the output frame, renormalised; "
      "composites incomplete requests at the deadline (one request period, or the 'latency' "
      "property, ns) in live pipelines (Yang et al. 2002, 4.3)",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess num-buffers=60 "
      "focal-surface=false ! tee name=t "
      "t. ! queue ! a.request t. ! queue ! b.request lfcamsrc rig=../shared/data/stanford-chess "
      "row=4 col=4 ! lffragment name=a rig=../shared/data/stanford-chess row=4 col=4 ! c. "
      "lfcamsrc rig=../shared/data/stanford-chess row=4 col=5 ! lffragment name=b "
      "rig=../shared/data/stanford-chess row=4 col=5 ! c. lfcompositor name=c ! videoconvert ! "
      "autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "Upstream custom events it sends: lf-focus (viewer-id, probe-id, inverse-depth, "
      "capture-time) and lf-surface (a focal surface: tile, cols, rows, planes, plane-of) "
      "answering the probes of lfviewrequest; navigation and lf-view events from the video sink go "
      "upstream tagged with its viewer-id. Warning messages, rate-limited, name what was dropped: "
      "a malformed fragment, a fragment of another size or outside the sequence window, a camera's "
      "second fragment for one request, a click that cannot be focused.");
  ec->request_new_pad = lf_compositor_request_new_pad;
  ac->start = lf_compositor_start;
  ac->stop = lf_compositor_stop;
  ac->sink_event = lf_compositor_sink_event;
  ac->negotiate = lf_compositor_negotiate;
  LfFragmentAggregatorClass* fc = LF_FRAGMENT_AGGREGATOR_CLASS(klass);
  fc->begin = lf_compositor_begin;
  fc->absorb = lf_compositor_absorb;
  fc->live_batch = lf_compositor_live_batch;
  fc->requests = lf_compositor_requests;
  fc->emit_due = lf_compositor_emit_due;
  fc->tag_upstream = lf_compositor_tag_upstream;
  GST_DEBUG_CATEGORY_INIT(lf_compositor_debug, "lfcompositor", 0, "light field compositor");
}
