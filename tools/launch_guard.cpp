// lf-launch's guard of plain RTP (see launch_guard.h).
#include "launch_guard.h"

#include <gst/rtp/gstrtpbuffer.h>

#include <deque>
#include <map>
#include <set>

#include "lf/wire/rtp_guard.h"

namespace {

// A packet the guard refused, kept in case its sequence takes the window.
struct Held {
  guint16 seq = 0;
  guint32 ts = 0;
  GstBuffer* buf = nullptr;  // (ref)
};
// Refused packets kept per SSRC: a sequence takes the window only after
// it was heard in a few 10-ms slots, and a camera host's fragments of one
// request are a burst of dozens of packets, so the first one (its caps)
// must outlast several bursts. At most 128 x MTU bytes an SSRC.
constexpr size_t kHeld = 128;

// One receiver's guards, one per SSRC its caps name (the stream's and its
// retransmission stream's), what they dropped and the packets they hold.
struct PlainReceiver {
  GstCaps* caps = nullptr;  // the caps the guards were made for (owned)
  guint ssrc = 0, rtx_ssrc = 0;
  gint clock_rate = 90000;
  std::map<guint, lf::RtpSequenceGuard> guards;
  std::map<guint, std::deque<Held>> held;  // the last kHeld refused packets of each SSRC
  std::set<guint> started;                 // SSRCs whose first packet passed
  bool releasing = false;                  // pushing held packets (they pass untouched)
  guint64 dropped = 0;
  gint64 reported_us = 0;
  guint64 reported = 0;
  int restarts = 0;
  void forget() {
    for (auto& [ssrc, q] : held)
      for (Held& h : q) gst_buffer_unref(h.buf);
    held.clear();
    started.clear();
  }
  ~PlainReceiver() {
    forget();
    if (caps) gst_caps_unref(caps);
  }
};

// Makes the guards for the pad's caps when they change (a new stream).
bool follow_caps(GstPad* pad, PlainReceiver* r) {
  GstCaps* caps = gst_pad_get_current_caps(pad);
  if (!caps) return false;
  if (r->caps && gst_caps_is_equal(caps, r->caps)) {
    gst_caps_unref(caps);
    return !r->guards.empty();
  }
  if (r->caps) gst_caps_unref(r->caps);
  r->caps = caps;
  r->guards.clear();
  r->forget();
  const GstStructure* s = gst_caps_get_size(caps) ? gst_caps_get_structure(caps, 0) : nullptr;
  gint rate = 0;
  if (!s || !gst_structure_has_name(s, "application/x-rtp") ||
      !gst_structure_get_uint(s, "ssrc", &r->ssrc))
    return false;
  if (!gst_structure_get_int(s, "clock-rate", &rate) || rate <= 0) rate = 90000;
  r->clock_rate = rate;
  if (!gst_structure_get_uint(s, "rtx-ssrc", &r->rtx_ssrc)) r->rtx_ssrc = r->ssrc;
  r->guards.emplace(r->ssrc, lf::RtpSequenceGuard(static_cast<uint32_t>(rate)));
  r->guards.emplace(r->rtx_ssrc, lf::RtpSequenceGuard(static_cast<uint32_t>(rate)));
  return true;
}

// When a sequence takes the window at (seq, ts), the packets of it that
// were refused before (a restarted sender's first ones, which carry its
// in-band caps: without them the depayloader dropped everything until the
// next caps, a second later) go on first: those up to kHeld sequence
// numbers behind it, with timestamps up to a second behind, in order, a sequence
// number held twice not at all (one of the two is forged).
void release_held(GstPad* pad, PlainReceiver* r, guint ssrc, guint16 seq, guint32 ts) {
  std::deque<Held> q;
  q.swap(r->held[ssrc]);
  std::map<guint16, GstBuffer*> out;  // by distance behind, farthest first (null: held twice)
  for (Held& h : q) {
    const auto behind = static_cast<guint16>(seq - h.seq);
    const auto ts_behind = static_cast<guint32>(ts - h.ts);
    if (behind >= 1 && behind <= kHeld && ts_behind <= static_cast<guint32>(r->clock_rate)) {
      auto [at, first] = out.emplace(static_cast<guint16>(kHeld - behind), h.buf);
      if (first) continue;  // its reference moves to `out`
      if (at->second) gst_buffer_unref(at->second), at->second = nullptr;
    }
    gst_buffer_unref(h.buf);
  }
  r->releasing = true;
  for (auto& [key, buf] : out)
    if (buf) gst_pad_push(pad, buf);
  r->releasing = false;
}

// Whether a packet passes: another SSRC's is left to the receivers' own
// SSRC check (lf-launch's only_own_ssrc), which drops it. A new stream's
// first packet (RFC 3550 A.1 probation) is dropped without being counted.
// With `pad` (a single buffer, not a list), a refused packet is held, and
// a packet that gives its sequence the window releases those held before.
bool passes(PlainReceiver* r, GstBuffer* buf, gint64 now, GstPad* pad = nullptr) {
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  if (!gst_rtp_buffer_map(buf, GST_MAP_READ, &rtp)) return true;  // not RTP: dropped later
  const guint ssrc = gst_rtp_buffer_get_ssrc(&rtp);
  const guint16 seq = gst_rtp_buffer_get_seq(&rtp);
  const guint32 ts = gst_rtp_buffer_get_timestamp(&rtp);
  gst_rtp_buffer_unmap(&rtp);
  auto it = r->guards.find(ssrc);
  if (it == r->guards.end()) return true;
  using V = lf::RtpSequenceGuard::Verdict;
  const int restarts = it->second.restarts();
  const V v = it->second.check(seq, ts, now);
  r->dropped += v == V::jump || v == V::timestamp;
  if (pad && v != V::accept) {
    std::deque<Held>& q = r->held[ssrc];
    if (q.size() == kHeld) gst_buffer_unref(q.front().buf), q.pop_front();
    q.push_back({seq, ts, gst_buffer_ref(buf)});
  } else if (pad && (it->second.restarts() != restarts || r->started.insert(ssrc).second)) {
    release_held(pad, r, ssrc, seq, ts);  // a new window, or the stream's first
  }
  return v == V::accept;
}

GstPadProbeReturn guard_packets(GstPad* pad, GstPadProbeInfo* info, gpointer data) {
  auto* r = static_cast<PlainReceiver*>(data);
  if (r->releasing || !follow_caps(pad, r)) return GST_PAD_PROBE_OK;
  const gint64 now = g_get_monotonic_time();
  GstPadProbeReturn ret = GST_PAD_PROBE_OK;
  if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER) {
    if (!passes(r, GST_PAD_PROBE_INFO_BUFFER(info), now, pad)) ret = GST_PAD_PROBE_DROP;
  } else {
    GstBufferList* list = gst_buffer_list_make_writable(GST_PAD_PROBE_INFO_BUFFER_LIST(info));
    for (guint i = 0; i < gst_buffer_list_length(list); ++i)
      if (!passes(r, gst_buffer_list_get(list, i), now)) gst_buffer_list_remove(list, i--, 1);
    GST_PAD_PROBE_INFO_DATA(info) = list;
    if (!gst_buffer_list_length(list)) ret = GST_PAD_PROBE_DROP;
  }
  int restarts = 0;
  for (const auto& [ssrc, g] : r->guards) restarts += g.restarts();
  if (restarts != r->restarts) {
    r->restarts = restarts;
    g_printerr("lf-launch: %s: SSRC %u started a new sequence (a restarted sender): followed\n",
               GST_OBJECT_NAME(GST_OBJECT_PARENT(pad)), r->ssrc);
  }
  // At most one line a second.
  if (r->dropped != r->reported && now - r->reported_us >= 1000000) {
    g_printerr("lf-launch: %s: %" G_GUINT64_FORMAT
               " packets with SSRC %u dropped so far: their "
               "sequence number or timestamp is not the stream's (forged, or a stray sender; plain "
               "RTP: use SRTP on an untrusted network)\n",
               GST_OBJECT_NAME(GST_OBJECT_PARENT(pad)), r->dropped, r->ssrc);
    r->reported = r->dropped;
    r->reported_us = now;
  }
  return ret;
}

}  // namespace

void guard_plain_rtp(GstPad* udpsrc_src) {
  gst_pad_add_probe(
      udpsrc_src,
      static_cast<GstPadProbeType>(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST),
      guard_packets, new PlainReceiver, [](gpointer d) { delete static_cast<PlainReceiver*>(d); });
}
