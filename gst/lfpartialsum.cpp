/**
 * SECTION:element-lfpartialsum
 * @title: lfpartialsum
 *
 * Adds up the fragments of one camera host's cameras for each view request
 * and sends one fragment, their partial sum (premultiplied colour and
 * weight summed per output pixel: lib/lf/render/composite.h sum_fragments; a
 * version-2 fragment, lib/lf/wire/wire.h, that tells the compositor how many
 * cameras it holds). `lfcompositor` adds it like any fragment and
 * renormalises by the total weight, so the frame is the same (bit for bit
 * where the sums fit 8 bits). It pays when the host's cameras are
 * neighbours, a contiguous block of the grid: their fragments overlap, and
 * the sum covers the block's part of the view once instead of about three
 * times (the tent weights every pixel from three cameras). The price: a
 * dead host leaves a hole where only its block sees (interleaved hosts do
 * not, but their fragments barely overlap). `lfcamerahost partial-sums=true`
 * puts one after its cameras.
 *
 * One sink pad per camera. A request's sum leaves when every pad has
 * answered it, or, live, at its deadline: the request's running time plus
 * the `latency` property (GstAggregator's; 20 ms by default here) with the
 * fragments that came; not live, pads are taken in step. The fragments
 * come raw from the cameras (in process: sealed, so no CRC is computed
 * twice) and the sum is encoded here (`encoding`, `jpeg-quality`), once.
 * Passed on unchanged, not summed: probe answers (lfcompositor scores each
 * camera's), and the requests some camera answered with two layers (a
 * focal surface's second planes: the compositor's per-pixel choice needs
 * each camera's colours). A malformed fragment, a fragment for a frame
 * larger than the view (the caps' width x height, else 3840 x 2160), and
 * more fragments for one request than there are sink pads are dropped
 * with a rate-limited warning; the request is summed from the rest.
 *
 * ## Example launch line
 * |[
 * gst-launch-1.0 udpsrc port=5000 caps=... ! rtpgstdepay ! \
 *   lfcamerahost rig=rig.json cameras=0-3,8-11,16-19,24-27 partial-sums=true \
 *   encoding=jpeg is-live=true ! rtpgstpay ! udpsink host=compositor port=5200
 * ]|
 */
#include <gst/base/gstaggregator.h>

#include <memory>
#include <utility>
#include <vector>

#include "lf/render/composite.h"
#include "lf/session/frame_assembly.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"
#include "lfaggregate.h"
#include "lfbackend.h"
#include "lfcaps.h"
#include "lffragmentaggregator.h"
#include "lfguard.h"
#include "lfmeta.h"
#include "lfprops.h"
#include "lftrace.h"
#include "lfwarn.h"

GST_DEBUG_CATEGORY_STATIC(lf_partial_sum_debug);
#define GST_CAT_DEFAULT lf_partial_sum_debug

G_BEGIN_DECLS
#define LF_TYPE_PARTIAL_SUM (lf_partial_sum_get_type())
G_DECLARE_FINAL_TYPE(LfPartialSum, lf_partial_sum, LF, PARTIAL_SUM, LfFragmentAggregator)
G_END_DECLS

#define DEFAULT_ENCODING lfgst::FragmentEncoding::kRaw
#define DEFAULT_JPEG_QUALITY 90
#define DEFAULT_LATENCY (20 * GST_MSECOND)

namespace {
struct Settings {
  lfgst::FragmentEncoding encoding = DEFAULT_ENCODING;
  gint quality = DEFAULT_JPEG_QUALITY;
  guint64 sums = 0;  // read-only: sums sent
};
// A fragment buffer held until its request leaves.
struct Held {
  GstBuffer* buffer = nullptr;
  bool layered = false;  // the camera answered with two layers: passed on
  explicit Held(GstBuffer* b, bool l) : buffer(gst_buffer_ref(b)), layered(l) {}
  Held(Held&& o) noexcept : buffer(std::exchange(o.buffer, nullptr)), layered(o.layered) {}
  Held(const Held&) = delete;
  Held& operator=(const Held&) = delete;
  ~Held() {
    if (buffer) gst_buffer_unref(buffer);
  }
};
// A request's fragments so far (lib/lf/session/frame_assembly.h), by
// (sequence, viewer), one per camera.
using Request = lf::PendingRequest<Held>;
// At most this many requests wait; beyond, the oldest leaves as it is.
constexpr size_t kMaxPending = 16;
// The largest output frame summed before the caps give the view's size
// (lffragment's default max-pixels): the sums' buffer grows with it.
constexpr size_t kDefaultMaxArea = size_t{3840} * 2160;
struct State {
  Settings s;
  size_t max_area = kDefaultMaxArea;  // the view's area once the caps give it
  lf::PendingRequests<std::pair<uint64_t, uint32_t>, Held> pending{kMaxPending};
  lfgst::WarnLimiter bad;
};
struct Priv {
  Settings settings;
  std::unique_ptr<State> state;
};
lfgst::Properties<Settings> props;
}  // namespace

struct _LfPartialSum {
  LfFragmentAggregator parent;
  Priv* priv;
};

G_DEFINE_TYPE(LfPartialSum, lf_partial_sum, LF_TYPE_FRAGMENT_AGGREGATOR)
GST_ELEMENT_REGISTER_DEFINE(lfpartialsum, "lfpartialsum", GST_RANK_NONE, LF_TYPE_PARTIAL_SUM)

static GstStaticPadTemplate sink_template = GST_STATIC_PAD_TEMPLATE(
    "sink_%u", GST_PAD_SINK, GST_PAD_REQUEST, GST_STATIC_CAPS(LF_FRAGMENT_CAPS));
static GstStaticPadTemplate src_template =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS, GST_STATIC_CAPS(LF_FRAGMENT_CAPS));

static void lf_partial_sum_property_set(GObject*, GParamSpec*, const GValue*) {}
LF_DEFINE_ELEMENT_GLUE(lf_partial_sum, LF_PARTIAL_SUM)

static gboolean lf_partial_sum_start(GstAggregator* agg) {
  LfPartialSum* self = LF_PARTIAL_SUM(agg);
  auto st = std::make_unique<State>();
  GST_OBJECT_LOCK(self);
  self->priv->settings.sums = 0;
  GST_OBJECT_UNLOCK(self);
  st->s = lfgst::snapshot(GST_OBJECT(self), self->priv->settings);
  self->priv->state = std::move(st);
  return TRUE;
}

static gboolean lf_partial_sum_stop(GstAggregator* agg) {
  LF_PARTIAL_SUM(agg)->priv->state.reset();
  return TRUE;
}

// The cameras' caps, with this element's encoding, go downstream.
static gboolean lf_partial_sum_sink_event(GstAggregator* agg, GstAggregatorPad* pad,
                                          GstEvent* event) {
  LfPartialSum* self = LF_PARTIAL_SUM(agg);
  GstCaps* in = nullptr;
  if (GST_EVENT_TYPE(event) == GST_EVENT_CAPS) gst_event_parse_caps(event, &in);
  const GstStructure* s = in && gst_caps_get_size(in) > 0 ? gst_caps_get_structure(in, 0) : nullptr;
  gint w = 0, h = 0;
  State* st = self->priv->state.get();
  const bool sized = s && gst_structure_get_int(s, "width", &w) &&
                     gst_structure_get_int(s, "height", &h) && w > 0 && h > 0;
  if (sized && st) st->max_area = static_cast<size_t>(w) * static_cast<size_t>(h);
  // Caps that carry the view's size and rate (lffragment's once requests
  // came), or the first caps.
  if (s && (sized || !gst_pad_has_current_caps(GST_AGGREGATOR_SRC_PAD(agg)))) {
    GstCaps* caps = lfgst::fragment_caps(
        lfgst::read_setting(GST_OBJECT(self), self->priv->settings, &Settings::encoding), in);
    gst_aggregator_set_src_caps(agg, caps);
    gst_caps_unref(caps);
  }
  return GST_AGGREGATOR_CLASS(lf_partial_sum_parent_class)->sink_event(agg, pad, event);
}

static GstFlowReturn forward(LfPartialSum* self, GstBuffer* buf) {
  return gst_aggregator_finish_buffer(GST_AGGREGATOR(self), gst_buffer_ref(buf));
}

// Files one buffer under its request, or passes it on (probe answers). A
// request holds at most one fragment per camera and one per sink pad.
static GstFlowReturn lf_partial_sum_absorb(LfFragmentAggregator* agg, GstAggregatorPad* pad,
                                           GstBuffer* buf) {
  LfPartialSum* self = LF_PARTIAL_SUM(agg);
  State* st = self->priv->state.get();
  GST_OBJECT_LOCK(self);
  const size_t npads = GST_ELEMENT(self)->numsinkpads;
  GST_OBJECT_UNLOCK(self);
  lf::FragmentHeader head;
  GError* err = nullptr;
  size_t size = 0;
  if (!lfgst::guard(
          [&] {
            lfgst::MappedBuffer m(buf, GST_MAP_READ);
            size = m.size();
            head = lf::peek_fragment_header(m.data(), m.size());
          },
          &err)) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE, ("Dropping a malformed fragment"),
                               "%s", err->message);
    g_error_free(err);
    return GST_FLOW_OK;
  }
  if (lf::is_focus_probe(head.sequence) || lf::is_surface_probe(head.sequence))
    return forward(self, buf);
  const std::pair<uint64_t, uint32_t> key{head.sequence, head.viewer_id};
  if (st->pending.count_of(key) >= npads) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE, ("Dropping a fragment"),
                               "request %" G_GUINT64_FORMAT
                               " has %zu fragments already, one per "
                               "sink pad (camera %u)",
                               head.sequence, st->pending.count_of(key), head.camera_id);
    return GST_FLOW_OK;
  }
  std::vector<Held> held;
  held.emplace_back(buf, head.size() < size);
  const GstClockTime pts = GST_BUFFER_PTS(buf);
  // A second fragment of a camera (a duplicate): dropped.
  st->pending.add(key, head.camera_id, 1, std::move(held),
                  GST_CLOCK_TIME_IS_VALID(pts)
                      ? gst_segment_to_running_time(&pad->segment, GST_FORMAT_TIME, pts)
                      : GST_CLOCK_TIME_NONE,
                  pts);
  return GST_FLOW_OK;
}

// Sends a request's sum (or its buffers as they are).
static GstFlowReturn emit(LfPartialSum* self, Request& g) {
  State* st = self->priv->state.get();
  std::vector<GstBuffer*> buffers;
  for (const Held& h : g.pieces) buffers.push_back(h.buffer);
  if (std::any_of(g.pieces.begin(), g.pieces.end(), [](const Held& h) { return h.layered; })) {
    GstFlowReturn ret = GST_FLOW_OK;
    for (GstBuffer* b : buffers)
      if (ret == GST_FLOW_OK) ret = forward(self, b);
    return ret;
  }
  const gint64 t0 = g_get_monotonic_time();
  std::vector<std::unique_ptr<lfgst::MappedBuffer>> maps;
  std::vector<lf::Fragment> parts(buffers.size());
  std::vector<lf::FragmentPixels> in;
  std::vector<uint8_t> bytes;
  lf::Fragment sum;
  GError* err = nullptr;
  // Each fragment checked on its own (a bad one is left out, not the
  // request): for a frame no larger than the view's.
  for (size_t i = 0; i < buffers.size(); ++i) {
    if (!lfgst::guard(
            [&] {
              auto m = std::make_unique<lfgst::MappedBuffer>(buffers[i], GST_MAP_READ);
              const uint8_t* px = nullptr;
              const bool sealed = lfgst::has_sealed_meta(buffers[i]);
              parts[i] = lf::parse_fragment_in_place(m->data(), m->size(), &px, nullptr,
                                                     st->max_area, !sealed);
              const size_t area = static_cast<size_t>(parts[i].out_width) * parts[i].out_height;
              if (area > st->max_area)
                throw lf::WireError("fragment: a frame of " + std::to_string(area) +
                                    " pixels, over the view's " + std::to_string(st->max_area));
              in.push_back({&parts[i], px});
              maps.push_back(std::move(m));
            },
            &err)) {
      LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE, ("Dropping a malformed fragment"),
                                 "%s", err->message);
      g_clear_error(&err);
    }
  }
  if (in.empty()) return GST_FLOW_OK;
  if (!lfgst::guard(
          [&] {
            sum = lf::sum_fragments(in);
            bytes =
                lf::serialize_fragment(sum, lfgst::wire_encoding(st->s.encoding), st->s.quality);
          },
          &err)) {
    LF_ELEMENT_WARNING_LIMITED(self, st->bad, STREAM, DECODE,
                               ("Dropping a request's fragments that cannot be summed"), "%s",
                               err->message);
    g_error_free(err);
    return GST_FLOW_OK;
  }
  GstBuffer* first = buffers.front();
  GstBuffer* out = gst_buffer_new_memdup(bytes.data(), bytes.size());
  GST_BUFFER_PTS(out) = GST_BUFFER_PTS(first);
  GST_BUFFER_DURATION(out) = GST_BUFFER_DURATION(first);
  GST_BUFFER_OFFSET(out) = sum.sequence;
  lfgst::trace(GST_ELEMENT(self), "summed", sum.viewer_id, sum.sequence,
               static_cast<gint>(sum.camera_id), static_cast<gint64>(sum.cameras),
               (g_get_monotonic_time() - t0) * 1000);
  GST_OBJECT_LOCK(self);
  self->priv->settings.sums++;
  GST_OBJECT_UNLOCK(self);
  return gst_aggregator_finish_buffer(GST_AGGREGATOR(self), out);
}

// Live: every buffer queued (each pad is one camera; the deadline paces them).
static gsize lf_partial_sum_live_batch(LfFragmentAggregator*) {
  return G_MAXSIZE;
}

static const lf::RequestTimes* lf_partial_sum_requests(LfFragmentAggregator* agg) {
  const State* st = LF_PARTIAL_SUM(agg)->priv->state.get();
  return st ? &st->pending : nullptr;
}

// Requests in order: complete ones, and at its deadline (or at the end, or
// with too many waiting) an incomplete one, summed from what came.
static GstFlowReturn lf_partial_sum_emit_due(LfFragmentAggregator* agg, const LfDeadline* d,
                                             gboolean all_eos) {
  LfPartialSum* self = LF_PARTIAL_SUM(agg);
  GST_OBJECT_LOCK(self);
  const size_t npads = GST_ELEMENT(self)->numsinkpads;
  GST_OBJECT_UNLOCK(self);
  return lfgst::emit_due(
      self->priv->state->pending, npads, [d](GstClockTime rt) { return lf_deadline_passed(d, rt); },
      all_eos, false,
      [&](const auto& key, Request& g, bool complete) {
        if (!complete)
          GST_DEBUG_OBJECT(self, "request %" G_GUINT64_FORMAT ": %zu of %zu cameras", key.first,
                           g.count, npads);
        return emit(self, g);
      });
}

static void lf_partial_sum_init(LfPartialSum* self) {
  self->priv = new Priv();
  g_object_set(self, "latency", static_cast<GstClockTime>(DEFAULT_LATENCY), nullptr);
}

static void lf_partial_sum_class_init(LfPartialSumClass* klass) {
  GObjectClass* oc = G_OBJECT_CLASS(klass);
  GstElementClass* ec = GST_ELEMENT_CLASS(klass);
  GstAggregatorClass* ac = GST_AGGREGATOR_CLASS(klass);
  oc->set_property = lf_partial_sum_set_property;
  oc->get_property = lf_partial_sum_get_property;
  oc->finalize = lf_partial_sum_finalize;
  props.add(oc, &Settings::encoding,
            g_param_spec_enum("encoding", "Encoding", "Encoding of the sums sent",
                              lfgst::fragment_encoding_type(), static_cast<gint>(DEFAULT_ENCODING),
                              lfgst::kReadWriteReady));
  props.add(oc, &Settings::quality,
            g_param_spec_int("jpeg-quality", "JPEG quality",
                             "JPEG quality of the sums (encoding=jpeg), 1..100", 1, 100,
                             DEFAULT_JPEG_QUALITY, lfgst::kReadWriteReady));
  props.add(oc, &Settings::sums,
            g_param_spec_uint64(
                "sums", "Sums", "Partial sums sent since the element started", 0, G_MAXUINT64, 0,
                static_cast<GParamFlags>(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS)));
  gst_element_class_add_static_pad_template_with_gtype(ec, &sink_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_add_static_pad_template_with_gtype(ec, &src_template, GST_TYPE_AGGREGATOR_PAD);
  gst_element_class_set_static_metadata(
      ec, "Light field partial sum", "Filter/Editor/Video/Compositor",
      "Adds up a camera host's fragments of each view request into one fragment (premultiplied "
      "colour and weight), for lfcompositor; sends incomplete sums at the deadline ('latency', "
      "ns) in live pipelines",
      "lightfield-gst");
  gst_element_class_add_static_metadata(
      ec, "Example",
      LF_TWO_CAMERA_EXAMPLE("s") "lfpartialsum name=s encoding=jpeg ! lfcompositor ! "
                                 "videoconvert ! autovideosink");
  gst_element_class_add_static_metadata(
      ec, "Events",
      "A rate-limited warning message for a malformed fragment, which is left out of the sum. "
      "Navigation and lf-view events from downstream go up every sink pad, to the cameras and on "
      "to lfviewrequest; seeks are refused.");
  ac->start = lf_partial_sum_start;
  ac->stop = lf_partial_sum_stop;
  ac->sink_event = lf_partial_sum_sink_event;
  LfFragmentAggregatorClass* fc = LF_FRAGMENT_AGGREGATOR_CLASS(klass);
  fc->absorb = lf_partial_sum_absorb;
  fc->live_batch = lf_partial_sum_live_batch;
  fc->requests = lf_partial_sum_requests;
  fc->emit_due = lf_partial_sum_emit_due;
  GST_DEBUG_CATEGORY_INIT(lf_partial_sum_debug, "lfpartialsum", 0, "light field partial sums");
}
