// lfcompositor, the compositor host (Yang et al. 2002, 4.3): glue (caps,
// events, messages) over lib/lf/session (frame_assembly.h, compositor_host.h,
// probe_scoring.h) and LfFragmentAggregator; its documentation, properties
// and metadata are in gst/lfcompositorprops.cpp.
#include <gst/base/gstaggregator.h>
#include <gst/video/video.h>

#include <algorithm>
#include <memory>
#include <optional>

#include "lf/session/compositor_host.h"
#include "lf/session/probe_scoring.h"
#include "lfaggregate.h"
#include "lfarrival.h"
#include "lfbackend.h"
#include "lfcompositorprops.h"
#include "lfdeadline.h"
#include "lfevents.h"
#include "lffragmentaggregator.h"
#include "lfguard.h"
#include "lfmemory.h"
#include "lfmeta.h"
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

namespace {
using Settings = lfgst::CompositorSettings;
// A fragment waiting for its frame: raw pixels in place in the received
// buffer, mapped until the frame leaves (lib/lf/session/compositor_host.h).
using Piece = lf::ReceivedPiece;
// A request waiting for its fragments (lib/lf/session/frame_assembly.h): a
// buffer's pieces are filed under its camera (viewer << 32 | camera).
using Request = lf::PendingRequest<Piece>;
// At most this many requests waiting.
constexpr size_t kMaxPending = 16;
// A probe is scored when every camera answered every step, or this long (at
// least the latency) after its first fragment, with what came.
constexpr gint64 kProbeDeadlineUs = G_USEC_PER_SEC;
// From start to stop (READY <-> PAUSED), on the aggregate thread only (sink events too).
struct State {
  Settings s;  // snapshot taken at start
  std::shared_ptr<const lf::Rig> rig;
  lf::PendingRequests<uint64_t, Piece> pending{kMaxPending};  // by request sequence
  guint64 conflicts = 0;  // fragments dropped as a second copy of a camera's in a request
  // The checks of each fragment's header: the viewer composited (viewer-id,
  // or the first seen) and the request window (lib/lf/session/compositor_host.h).
  std::optional<lf::FragmentIntake> intake;
  // The frames, made by the renderer (lib/lf/render/renderer.h: the CPU
  // kernels, or GL) chosen at start by `backend`; its image slots hold the
  // camera frames of drawings left to us (each uploaded once with GL).
  std::optional<lf::FrameCompositor> frames;
  lfgst::RawVideoOutput output;                 // the negotiated raw video (gst/lfvideoout.h)
  std::optional<lfgst::ViewFormat> format;      // the view's size and rate: properties or caps
  std::optional<lf::ProbeScoring> probes;       // focus and surface probes being collected
  lf::OutputRate rate;                          // frames out a second: the lf-rate message
  GstClockTime taken_at = GST_CLOCK_TIME_NONE;  // running time of this aggregate()'s fragments
  lfgst::WarnLimiter no_focus, no_surface, bad, foreign, out_of_window, duplicate;
  // The warnings of fragments dropped by the intake's checks, one per verdict.
  lfgst::WarnLimiter dropped[static_cast<int>(lf::Intake::Verdict::kOverBudget) + 1];
};

struct Priv {
  Settings settings;  // properties (object lock)
  std::unique_ptr<State> state;
  lfgst::CompositorDeadline deadline;  // the aggregator's latency (gst/lfdeadline.h)
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
  self->priv->settings.frames = self->priv->settings.over_budget = 0;
  self->priv->settings.last_cameras = 0;
  GST_OBJECT_UNLOCK(self);
  st->s = lfgst::snapshot(GST_OBJECT(self), self->priv->settings);
  if (!st->s.rig.empty()) {
    st->rig = lfgst::open_rig(GST_ELEMENT(self), st->s.rig);
    if (!st->rig) return FALSE;
  }
  st->intake.emplace(st->rig, st->s.viewer_id);
  st->format.emplace(st->s.width, st->s.height, st->s.framerate);
  st->probes.emplace(st->rig);
  std::unique_ptr<lf::Renderer> renderer;
  if (!lfgst::open_renderer(GST_ELEMENT(self), st->s.backend, renderer)) return FALSE;
  st->frames.emplace(std::move(renderer));
  self->priv->deadline.reset(GST_AGGREGATOR(self));
  self->priv->state = std::move(st);
  return TRUE;
}

static gboolean lf_compositor_stop(GstAggregator* agg) {
  LF_COMPOSITOR(agg)->priv->state.reset();
  LF_COMPOSITOR(agg)->priv->arrival.stop();
  return TRUE;
}

// Publishes what absorb() accepts now (aggregate thread), for the arrival decoder.
static void publish_acceptance(Priv* p, const State* st) {
  int w = 0, h = 0;
  p->arrival.publish(st->format->view_size(&w, &h) ? static_cast<uint64_t>(w) * h : 0,
                     st->intake->viewer.viewer(), st->s.stereo, st->intake->window.last_emitted());
}

static gboolean lf_compositor_sink_event(GstAggregator* agg, GstAggregatorPad* pad,
                                         GstEvent* event) {
  LfCompositor* self = LF_COMPOSITOR(agg);
  State* st = self->priv->state.get();
  if (GST_EVENT_TYPE(event) == GST_EVENT_CAPS && st) {
    GstCaps* caps;
    gst_event_parse_caps(event, &caps);
    if (st->format->take_caps(GST_ELEMENT(self), caps, lfgst::kMaxOutputSide)) {
      const lfgst::Fraction fps = st->format->fps();
      self->priv->deadline.set_period(agg, gst_util_uint64_scale_int(GST_SECOND, fps.d, fps.n));
      int w = 0, h = 0;  // for the cameras' run-ahead when not live (gst/lfdeadline.h)
      if (st->format->view_size(&w, &h)) self->priv->deadline.set_view_pixels(w * h);
    }
  }
  return GST_AGGREGATOR_CLASS(lf_compositor_parent_class)->sink_event(agg, pad, event);
}

static gboolean lf_compositor_src_query(GstAggregator* agg, GstQuery* query) {
  return LF_COMPOSITOR(agg)->priv->deadline.src_query(
      agg, query, GST_AGGREGATOR_CLASS(lf_compositor_parent_class)->src_query);
}

// Fragments in a complete request: the rig's cameras, else one per sink pad (x2 in stereo).
static size_t expected_fragments(LfCompositor* self) {
  State* st = self->priv->state.get();
  GST_OBJECT_LOCK(self);
  const size_t n = st->rig ? st->rig->cameras.size() : GST_ELEMENT(self)->numsinkpads;
  GST_OBJECT_UNLOCK(self);
  return n * (st->s.stereo ? 2 : 1);  // stereo: a left and a right fragment each
}

// GstAggregator's own negotiation (at start, on a reconfigure) would fix the
// template's 2x2 at 0/1 fps before the view size is known (vp8enc then drops
// every frame): emit() negotiates at the next frame instead (aggregate thread).
static gboolean lf_compositor_negotiate(GstAggregator* agg) {
  if (State* st = LF_COMPOSITOR(agg)->priv->state.get()) st->output.renegotiate();
  return TRUE;
}

static GstFlowReturn emit(LfCompositor* self, uint64_t seq, Request& g, bool complete) {
  State* st = self->priv->state.get();
  const gint64 t0 = g_get_monotonic_time();
  int w = 0, H = 0;
  if (!st->format->view_size(&w, &H)) return GST_FLOW_OK;  // nothing was accepted without a size
  const int W = st->s.stereo ? 2 * w : w;                  // stereo: left | right side by side
  if (!st->output.negotiate(GST_AGGREGATOR(self), W, H, st->format->fps()))
    return GST_FLOW_NOT_NEGOTIATED;
  const guint left_id = static_cast<guint>(std::max<int64_t>(0, st->intake->viewer.viewer()));
  // Each eye's fragments and the drawings lffragment left to us (defer:
  // whole-view mode), composited at once (lib/lf/session/compositor_host.h);
  // one eye straight into the output buffer where its video allows
  // (gst/lfvideoout.h), a stereo pair side by side first.
  lf::FrameCompositor::Result r;
  GstBuffer* out = nullptr;
  const auto make = [&](cv::Mat* into, const cv::Mat* last) -> const cv::Mat& {
    r = into ? st->frames->composite_into(g.pieces, w, H, complete, *into, *last)
             : st->frames->composite(g.pieces, w, H, st->s.stereo, left_id, complete);
    if (lfgst::trace_enabled())
      lfgst::trace_frame(GST_ELEMENT(self), left_id, seq, static_cast<gint64>(g.count),
                         r.frame->data, r.frame->total() * r.frame->elemSize(),
                         (g_get_monotonic_time() - t0) * 1000, r.filled);
    return *r.frame;
  };
  GError* err = nullptr;
  if (!lfgst::guard([&] { out = st->output.make_frame(!st->s.stereo, make); }, &err)) {
    GST_ELEMENT_ERROR(self, STREAM, FAILED, ("Cannot composite the frame"), ("%s", err->message));
    g_error_free(err);
    return GST_FLOW_ERROR;
  }
  for (const auto& [camera, why] : r.refused)
    GST_WARNING_OBJECT(self, "dropping fragment of camera %d: %s", camera, why.c_str());
  if (r.filled)  // a missed deadline: pixels from the last frame
    GST_DEBUG_OBJECT(self, "request %" G_GUINT64_FORMAT ": %zu pixels from the last frame", seq,
                     r.filled);
  GST_BUFFER_PTS(out) = g.pts;
  GST_BUFFER_DURATION(out) = g.duration;
  GST_BUFFER_OFFSET(out) = seq;
  st->intake->window.emitted(seq);
  // Before the frame goes out: whoever sees it may rely on the new window.
  publish_acceptance(self->priv, st);
  GST_OBJECT_LOCK(self);
  self->priv->settings.frames++;
  self->priv->settings.last_cameras = static_cast<guint>(g.count);
  GST_OBJECT_UNLOCK(self);
  if (const auto r = st->rate.frame(t0, complete))  // once a second (gst/lfevents.h)
    lfgst::post_rate(GST_ELEMENT(self), st->intake->viewer.viewer(), st->format->fps().value(), *r,
                     st->intake->budget.refused(), st->pending.shed());
  GstAggregator* agg = GST_AGGREGATOR(self);
  if (GST_CLOCK_TIME_IS_VALID(g.pts)) {
    GstSegment* seg = &GST_AGGREGATOR_PAD(agg->srcpad)->segment;
    seg->position = g.pts + (GST_CLOCK_TIME_IS_VALID(g.duration) ? g.duration : 0);
  }
  GST_LOG_OBJECT(self, "request %" G_GUINT64_FORMAT ": %zu fragments", seq, g.pieces.size());
  return gst_aggregator_finish_buffer(agg, out);
}

// A fragment of another viewer: after a while of only those (lf::ViewerSelection),
// warn once that viewer-id names a viewer that is not there (else: silence).
static void note_foreign(LfCompositor* self, State* st, guint viewer) {
  GST_LOG_OBJECT(self, "fragment of viewer %u: not ours", viewer);
  const gint64 now = g_get_monotonic_time();
  if (!st->intake->viewer.foreign(now)) return;
  GST_ELEMENT_WARNING(self, STREAM, WRONG_TYPE,
                      ("No fragments of viewer %" G_GINT64_FORMAT, st->intake->viewer.viewer()),
                      ("%s", st->intake->viewer.foreign_detail(now, viewer).c_str()));
}

// Sends what probe scoring (lib/lf/session/probe_scoring.h) gave upstream:
// an lf-focus event (the depth under a clicked pixel) or an lf-surface
// event (gst/lfevents.h), which lfviewrequest applies; or a warning.
static void send_probe_outcomes(LfCompositor* self, State* st) {
  using Result = lf::ProbeOutcome::Result;
  for (lf::ProbeOutcome& o : st->probes->take()) {
    const bool focus = o.kind == lf::ProbeOutcome::Kind::kFocus;
    if (o.result == Result::kSatOut || o.result == Result::kIncomplete) {
      GST_INFO_OBJECT(self, "%s", o.describe().c_str());
    } else if (o.result == Result::kFailed) {
      LF_ELEMENT_WARNING_LIMITED(self, focus ? st->no_focus : st->no_surface, STREAM, FAILED,
                                 ("%s", o.summary()), "%s", o.describe().c_str());
    } else {
      lfgst::trace(GST_ELEMENT(self), focus ? "focused" : "surface", o.viewer, o.probe, -1,
                   focus ? static_cast<gint64>(o.inverse_depth * 1e9) : o.planes_used);
      GST_DEBUG_OBJECT(self, "%s", o.describe().c_str());
      lf_fragment_aggregator_push_upstream(
          LF_FRAGMENT_AGGREGATOR(self),
          gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, lfgst::answer_structure(std::move(o))));
    }
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

// Parses one fragment buffer and files it under its request, once its
// header passed the checks (lf::FragmentIntake: the viewer, the camera, the
// output size and the sequence window, before anything is decoded).
static void absorb(LfCompositor* self, GstAggregatorPad* pad, GstBuffer* buf) {
  using V = lf::Intake::Verdict;
  State* st = self->priv->state.get();
  GError* err = nullptr;
  std::optional<lfgst::MappedBuffer> mapped;
  if (!lfgst::guard([&] { mapped.emplace(buf, GST_MAP_READ); }, &err)) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE, ("Dropping a malformed fragment"),
                               "%s", err->message);
    g_error_free(err);
    return;
  }
  int w = 0, h = 0;
  st->format->view_size(&w, &h);
  const gint64 t0 = g_get_monotonic_time();
  lf::Intake in = st->intake->take(mapped->data(), mapped->size(), !lfgst::has_sealed_meta(buf), w,
                                   h, st->s.stereo, t0);
  const lf::FragmentHeader& head = in.head;
  if (st->s.adaptive_deadline && (in.verdict == V::kAccept || in.late))  // how late they come
    self->priv->deadline.arrived(pad, buf, st->taken_at);
  if (in.verdict == V::kProbe)
    return absorb_probe_answer(self, st, mapped->data(), mapped->size(), w, h);
  if (in.verdict == V::kForeign) return note_foreign(self, st, head.viewer_id);
  if (in.verdict == V::kOutsideWindow) return;  // late, or on probation (lf::RequestWindow)
  if (in.verdict != V::kAccept) {
    if (in.verdict == V::kOverBudget)
      lfgst::write_setting<Settings, guint64>(GST_OBJECT(self), self->priv->settings,
                                              &Settings::over_budget, st->intake->budget.refused());
    lfgst::WarnLimiter& limiter = st->dropped[static_cast<int>(in.verdict)];
    LF_ELEMENT_WARNING_LIMITED(self, limiter, STREAM, DECODE, ("%s", in.summary()), "%s",
                               in.why.c_str());
    return;
  }
  if (in.followed) {
    LF_ELEMENT_WARNING_LIMITED(self, st->out_of_window, STREAM, DECODE,
                               ("Following a new request sequence"),
                               "fragments of requests %" G_GINT64_FORMAT " and %" G_GUINT64_FORMAT
                               " arrive, outside the window (a restarted viewer, or requests "
                               "lost for a while)",
                               in.candidate, head.sequence);
    st->pending.clear();
  }
  std::vector<lf::AnswerPiece>& parts = in.parts;
  const lf::Fragment& f = parts.front().f;
  gint64 on_arrival_ns = 0;
  lfgst::ArrivalDecoder::decoded(buf, &on_arrival_ns);
  lfgst::trace(GST_ELEMENT(self), "decoded", f.viewer_id, f.sequence,
               static_cast<gint>(f.camera_id),
               (g_get_monotonic_time() - t0) * 1000 + on_arrival_ns);
  if (st->intake->viewer.taken(f.viewer_id))  // viewer-id -1: the first viewer seen, then only it
    GST_INFO_OBJECT(self, "compositing viewer %u", f.viewer_id);
  const uint64_t seq = f.sequence;
  const uint64_t source = (static_cast<uint64_t>(f.viewer_id) << 32) | f.camera_id;
  const size_t cameras = f.cameras;
  const uint32_t camera = f.camera_id;
  const bool any_raw = std::any_of(parts.begin(), parts.end(), [](const lf::AnswerPiece& a) {
    return a.encoding == lf::Encoding::kRaw;
  });
  std::vector<Piece> pieces = lf::received_pieces(
      std::move(parts),
      any_raw ? std::make_shared<const lfgst::MappedBuffer>(std::move(*mapped)) : nullptr);
  // Drawings left to us (one, or a layer pair's two: a second piece).
  if (pieces.front().f.empty() && pieces.size() == 1) {
    auto d = lfgst::deferred_drawings(buf, static_cast<int>(camera), w, h);
    if (d.size() == 2) pieces.push_back(pieces.front()), pieces.back().f.layer = 1;
    for (size_t k = 0; k < d.size(); ++k) pieces[k].deferred = std::move(d[k]);
  }
  const GstClockTime pts = GST_BUFFER_PTS(buf);
  const GstClockTime rt = GST_CLOCK_TIME_IS_VALID(pts)
                              ? gst_segment_to_running_time(&pad->segment, GST_FORMAT_TIME, pts)
                              : GST_CLOCK_TIME_NONE;
  if (st->pending.add(seq, source, cameras, std::move(pieces), rt, pts, GST_BUFFER_DURATION(buf)) ==
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

// `stereo` may change while playing: the requests from here on follow it.
static void lf_compositor_begin(LfFragmentAggregator* agg) {
  LfCompositor* self = LF_COMPOSITOR(agg);
  State* st = self->priv->state.get();
  st->s.stereo = lfgst::read_setting(GST_OBJECT(self), self->priv->settings, &Settings::stereo);
  // One clock reading for the fragments this aggregate() takes (once per
  // fragment was 1 % of the CPU at 640x480 with 64 cameras).
  if (st->s.adaptive_deadline) st->taken_at = lfgst::running_now(GST_ELEMENT(self));
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
  st->intake->max_pixel_rate = d->live ? st->s.max_pixel_rate : 0;  // not live: every request
  // Live: surface estimates in the background (40 ms at 1080p); not live: reproducible.
  st->probes->set_background(d->live);
  st->probes->expire(g_get_monotonic_time(), probe_deadline_us);
  if (d->live && st->s.adaptive_deadline)
    if (const GstClockTime v = self->priv->deadline.adapt(GST_AGGREGATOR(agg)))
      GST_INFO_OBJECT(self, "deadline %.1f ms (the fragments' arrival times)", v / 1e6);
  send_probe_outcomes(self, st);
  const size_t expected = expected_fragments(self);
  auto due = [d](GstClockTime rt) { return lf_deadline_passed(d, rt); };
  const GstFlowReturn ret = lfgst::emit_due(
      st->pending, expected, due, all_eos, d->live, [&](uint64_t seq, Request& g, bool complete) {
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

// Its frames freed once idle (LfFragmentAggregator's release_idle), and the
// heap trimmed: a viewer gone quiet leaves its memory behind no longer.
static gboolean lf_compositor_release_idle(LfFragmentAggregator* agg, gboolean release) {
  State* st = LF_COMPOSITOR(agg)->priv->state.get();
  if (!st || !release) return st && st->frames->holds_memory();
  if (st->frames->release()) st->output.release(), lfgst::trim_heap();
  return TRUE;
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
  return lfgst::address_to_viewer(
      event, lfgst::read_setting(GST_OBJECT(agg), LF_COMPOSITOR(agg)->priv->settings,
                                 &Settings::viewer_id));
}

static void on_latency_changed(GObject* obj, GParamSpec*, gpointer) {
  LF_COMPOSITOR(obj)->priv->deadline.apply(GST_AGGREGATOR(obj));
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
  lfgst::install_compositor_properties(oc, &props);
  gst_element_class_add_static_pad_template_with_gtype(ec, &sink_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype(ec, &src_template, GST_TYPE_AGGREGATOR_PAD);
  lfgst::describe_compositor(ec);
  ec->request_new_pad = lf_compositor_request_new_pad;
  ac->start = lf_compositor_start;
  ac->stop = lf_compositor_stop;
  ac->sink_event = lf_compositor_sink_event;
  ac->src_query = lf_compositor_src_query;
  ac->negotiate = lf_compositor_negotiate;
  LfFragmentAggregatorClass* fc = LF_FRAGMENT_AGGREGATOR_CLASS(klass);
  fc->begin = lf_compositor_begin;
  fc->absorb = lf_compositor_absorb;
  fc->live_batch = lf_compositor_live_batch;
  fc->release_idle = lf_compositor_release_idle;
  fc->requests = lf_compositor_requests;
  fc->emit_due = lf_compositor_emit_due;
  fc->tag_upstream = lf_compositor_tag_upstream;
  GST_DEBUG_CATEGORY_INIT(lf_compositor_debug, "lfcompositor", 0, "light field compositor");
}
