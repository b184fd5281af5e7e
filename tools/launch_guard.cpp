// lf-launch's guard of plain RTP (see launch_guard.h).
#include "launch_guard.h"

#include <gst/rtp/gstrtpbuffer.h>

#include <map>

#include "lf/wire/rtp_guard.h"

namespace {

// One receiver's guards, one per SSRC its caps name (the stream's and its
// retransmission stream's), and what they dropped.
struct PlainReceiver {
  GstCaps* caps = nullptr;  // the caps the guards were made for (owned)
  guint ssrc = 0, rtx_ssrc = 0;
  std::map<guint, lf::RtpSequenceGuard> guards;
  guint64 dropped = 0;
  gint64 reported_us = 0;
  guint64 reported = 0;
  int restarts = 0;
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
  const GstStructure* s = gst_caps_get_size(caps) ? gst_caps_get_structure(caps, 0) : nullptr;
  gint rate = 0;
  if (!s || !gst_structure_has_name(s, "application/x-rtp") ||
      !gst_structure_get_uint(s, "ssrc", &r->ssrc))
    return false;
  if (!gst_structure_get_int(s, "clock-rate", &rate) || rate <= 0) rate = 90000;
  if (!gst_structure_get_uint(s, "rtx-ssrc", &r->rtx_ssrc)) r->rtx_ssrc = r->ssrc;
  r->guards.emplace(r->ssrc, lf::RtpSequenceGuard(static_cast<uint32_t>(rate)));
  r->guards.emplace(r->rtx_ssrc, lf::RtpSequenceGuard(static_cast<uint32_t>(rate)));
  return true;
}

// Whether a packet passes: another SSRC's is left to the receivers' own
// SSRC check (lf-launch's only_own_ssrc), which drops it. A new stream's
// first packet (RFC 3550 A.1 probation) is dropped without being counted.
bool passes(PlainReceiver* r, GstBuffer* buf, gint64 now) {
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  if (!gst_rtp_buffer_map(buf, GST_MAP_READ, &rtp)) return true;  // not RTP: dropped later
  const guint ssrc = gst_rtp_buffer_get_ssrc(&rtp);
  const guint16 seq = gst_rtp_buffer_get_seq(&rtp);
  const guint32 ts = gst_rtp_buffer_get_timestamp(&rtp);
  gst_rtp_buffer_unmap(&rtp);
  auto it = r->guards.find(ssrc);
  if (it == r->guards.end()) return true;
  using V = lf::RtpSequenceGuard::Verdict;
  const V v = it->second.check(seq, ts, now);
  r->dropped += v == V::jump || v == V::timestamp;
  return v == V::accept;
}

GstPadProbeReturn guard_packets(GstPad* pad, GstPadProbeInfo* info, gpointer data) {
  auto* r = static_cast<PlainReceiver*>(data);
  if (!follow_caps(pad, r)) return GST_PAD_PROBE_OK;
  const gint64 now = g_get_monotonic_time();
  GstPadProbeReturn ret = GST_PAD_PROBE_OK;
  if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER) {
    if (!passes(r, GST_PAD_PROBE_INFO_BUFFER(info), now)) ret = GST_PAD_PROBE_DROP;
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
      guard_packets, new PlainReceiver, [](gpointer d) {
        auto* r = static_cast<PlainReceiver*>(d);
        if (r->caps) gst_caps_unref(r->caps);
        delete r;
      });
}
