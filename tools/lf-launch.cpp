// lf-launch: runs a gst-launch-style pipeline description on a clock shared
// across machines (gst-launch-1.0 cannot select a network clock).
//  * --clock-server PORT: the pipeline runs on this machine's system clock,
//    which is published with GstNetTimeProvider on PORT (UDP).
//  * --clock-client HOST:PORT: the pipeline runs on a GstNetClientClock
//    slaved to that provider, after it has synchronised.
// All hosts must use the same --base-time (ns on the shared clock): then
// running time k * period is the same instant everywhere and the capture
// schedules of lfcamsrc align within the clock error (paper 4.4.4). With
// --base-time now+MS the server picks "now + MS ms" and prints it
// (`base-time NS`) for the clients.
// --rtp-clock-rate PT=HZ answers every rtpjitterbuffer's request-pt-map for
// payload type PT with that clock rate: the forward error correction packets
// (rtpulpfecenc) that share a stream's SSRC and sequence numbers under a
// payload type of their own. Without it the jitter buffer drops each parity
// packet ("No clock-rate in caps!"), waits its whole latency for the gap,
// and the decoder never sees the packet in order. Any other payload type
// stays unanswered, so the jitter buffer drops it: a forged packet of a
// third type never reaches an rtpptdemux, which would make a pad for it
// that nothing is linked to and stop the stream.
// Every RTP receiver drops packets of an SSRC other than its caps' (see
// only_own_ssrc). Retransmission (RFC 4588) without rtpbin, as
// rtprtxreceive's documentation lays it out (rtpsession ! rtprtxreceive !
// rtpjitterbuffer, rtprtxsend ! rtpsession), needs two more things
// gst-launch cannot give:
//  * every rtprtxreceive's retransmission requests get the SSRC of its
//    stream (its caps' "ssrc"): rtpjitterbuffer leaves it out and relies on
//    an rtpssrcdemux to add it, and rtpsession sends no NACK without one.
//    An rtpssrcdemux would give its one linked pad to whichever SSRC came
//    first, a forged one included.
//  * a sending rtpsession (RTCP in, RTP out) accepts NACKs for at most
//    --rtx-budget percent of the packets it has sent (plus a burst of 64): a
//    NACK names up to 17 packets in 4 bytes, so anyone who can send RTCP to
//    a camera host could otherwise make it resend its whole history again
//    and again. An RTCP packet whose NACKs would go over is dropped before
//    rtpsession turns them into a retransmission request each.
//  * with --rtcp-from ADDR[,ADDR...], a sending rtpsession takes RTCP only
//    from those addresses (the sender address udpsrc puts on each packet):
//    without it, anyone's forged NACKs spend the budget, and a packet the
//    compositor really lost is then not sent again (net_deploy's attacker
//    beside RTX=1 left 7 of 67 frames a fragment or two short once in 11
//    runs). A sender that forges the allowed address is still let in: on
//    an untrusted network, authenticate (SRTP_KEY, without RTX).
// Every plain RTP receiver (udpsrc with RTP caps naming an SSRC) drops
// packets whose sequence number or timestamp is not its stream's
// (launch_guard.h).
// Every srtpenc encrypts under a key of this start (derived from its key
// and a random MKI, so a restarted sender never reuses keystream), and
// every srtpdec is watched: it is given the keys of the MKIs its stream
// carries, and a stream that stops authenticating while its packets keep
// coming (a sender restarted within the session) has its SRTP state reset,
// so the sender is heard again (launch_srtp.h).
#include <gst/gst.h>
#include <gst/net/gstnet.h>
#include <gst/rtp/gstrtcpbuffer.h>
#include <gst/rtp/gstrtpbuffer.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "launch_guard.h"
#include "launch_srtp.h"

namespace {

const char* kSummary =
    "Runs a gst-launch-style pipeline description on a clock shared across machines.\n"
    "Give exactly one of --clock-server and --clock-client; every host uses the same\n"
    "--base-time.";

GstClockTime parse_base(const std::string& s, GstClock* clock) {
  if (s.rfind("now+", 0) == 0)
    return gst_clock_get_time(clock) + std::stoull(s.substr(4)) * GST_MSECOND;
  return std::stoull(s);
}

// The payload type and clock rate of --rtp-clock-rate.
struct PtClock {
  guint pt = 0;
  gint rate = 0;
};

// request-pt-map of an rtpjitterbuffer: RTP caps at the clock rate given,
// for its payload type only (nullptr: the jitter buffer drops the packet).
GstCaps* pt_map(GstElement*, guint pt, gpointer data) {
  const auto* c = static_cast<const PtClock*>(data);
  if (pt != c->pt) return nullptr;
  return gst_caps_new_simple("application/x-rtp", "clock-rate", G_TYPE_INT, c->rate, "payload",
                             G_TYPE_INT, static_cast<gint>(pt), nullptr);
}

// Calls fn(element, factory name) for every element of the pipeline.
template <typename Fn>
void for_each_element(GstElement* pipeline, Fn fn) {
  GstIterator* it = gst_bin_iterate_recurse(GST_BIN(pipeline));
  GValue v = G_VALUE_INIT;
  while (gst_iterator_next(it, &v) == GST_ITERATOR_OK) {
    GstElement* e = GST_ELEMENT(g_value_get_object(&v));
    GstElementFactory* f = gst_element_get_factory(e);
    fn(e, f ? GST_OBJECT_NAME(f) : "");
    g_value_reset(&v);
  }
  g_value_unset(&v);
  gst_iterator_free(it);
}

// Connects pt_map to every rtpjitterbuffer in the pipeline.
void answer_pt_maps(GstElement* pipeline, const PtClock* c) {
  for_each_element(pipeline, [c](GstElement* e, const char* kind) {
    if (g_str_equal(kind, "rtpjitterbuffer"))
      g_signal_connect(e, "request-pt-map", G_CALLBACK(pt_map), const_cast<PtClock*>(c));
  });
}

// A field of the pad's current caps (false: no caps, or no such field).
bool caps_uint(GstPad* pad, const char* field, guint* value) {
  GstCaps* caps = gst_pad_get_current_caps(pad);
  const bool known = caps && gst_caps_get_size(caps) > 0 &&
                     gst_structure_get_uint(gst_caps_get_structure(caps, 0), field, value);
  if (caps) gst_caps_unref(caps);
  return known;
}

const auto kBufferProbes =
    static_cast<GstPadProbeType>(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST);

bool is_rtx_request(GstEvent* ev) {
  if (GST_EVENT_TYPE(ev) != GST_EVENT_CUSTOM_UPSTREAM) return false;
  const GstStructure* s = gst_event_get_structure(ev);
  return s && gst_structure_has_name(s, "GstRTPRetransmissionRequest");
}

// Upstream on an rtprtxreceive's src pad: a retransmission request without
// an SSRC gets the stream's, from the pad's caps (dropped if they have none).
GstPadProbeReturn add_ssrc(GstPad* pad, GstPadProbeInfo* info, gpointer) {
  GstEvent* ev = GST_PAD_PROBE_INFO_EVENT(info);
  if (!is_rtx_request(ev) || gst_structure_has_field(gst_event_get_structure(ev), "ssrc"))
    return GST_PAD_PROBE_OK;
  guint ssrc = 0;
  if (!caps_uint(pad, "ssrc", &ssrc)) return GST_PAD_PROBE_DROP;
  ev = GST_EVENT(gst_mini_object_make_writable(GST_MINI_OBJECT(ev)));
  gst_structure_set(gst_event_writable_structure(ev), "ssrc", G_TYPE_UINT, ssrc, nullptr);
  GST_PAD_PROBE_INFO_DATA(info) = ev;
  return GST_PAD_PROBE_OK;
}

// A sending rtpsession's budget: `percent` of a token per RTP packet sent,
// one per packet that an incoming NACK asks for, at most kBurst saved.
struct RtxBudget {
  static constexpr long kBurst = 64;
  double percent = 25;
  std::atomic<long> milli_tokens{kBurst * 1000L};
  std::atomic<long> refused{0};
  std::vector<GInetAddress*> from;  // --rtcp-from (owned); empty: any sender
  std::atomic<long> foreign{0};     // RTCP packets from anyone else, dropped
  ~RtxBudget() {
    for (GInetAddress* a : from) g_object_unref(a);
  }
};
// Whether `buf` came from one of `from` (udpsrc's GstNetAddressMeta); a
// packet without a sender address is not let in either.
bool from_allowed(GstBuffer* buf, const std::vector<GInetAddress*>& from) {
  if (from.empty()) return true;
  GstNetAddressMeta* meta = gst_buffer_get_net_address_meta(buf);
  if (!meta || !G_IS_INET_SOCKET_ADDRESS(meta->addr)) return false;
  GInetAddress* a = g_inet_socket_address_get_address(G_INET_SOCKET_ADDRESS(meta->addr));
  for (GInetAddress* f : from)
    if (g_inet_address_equal(a, f)) return true;
  return false;
}
GstPadProbeReturn count_packet(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* b = static_cast<RtxBudget*>(data);
  long n = 1;
  if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER_LIST)
    n = gst_buffer_list_length(GST_PAD_PROBE_INFO_BUFFER_LIST(info));
  const long add = static_cast<long>(n * b->percent * 10);  // percent of 1000 milli-tokens
  long cur = b->milli_tokens.load();
  while (
      !b->milli_tokens.compare_exchange_weak(cur, std::min(cur + add, RtxBudget::kBurst * 1000L))) {
  }
  return GST_PAD_PROBE_OK;
}
// Packets an RTCP compound packet's generic NACKs (RFC 4585 6.2.1) ask for:
// each FCI, its packet and one per bit of its bitmask. -1: not RTCP.
long nacked_packets(GstBuffer* buf) {
  GstRTCPBuffer rtcp = GST_RTCP_BUFFER_INIT;
  if (!gst_rtcp_buffer_map(buf, GST_MAP_READ, &rtcp)) return -1;
  long n = 0;
  GstRTCPPacket pkt;
  for (gboolean more = gst_rtcp_buffer_get_first_packet(&rtcp, &pkt); more;
       more = gst_rtcp_packet_move_to_next(&pkt)) {
    if (gst_rtcp_packet_get_type(&pkt) != GST_RTCP_TYPE_RTPFB ||
        gst_rtcp_packet_fb_get_type(&pkt) != GST_RTCP_RTPFB_TYPE_NACK)
      continue;
    const guint8* fci = gst_rtcp_packet_fb_get_fci(&pkt);
    const guint words = gst_rtcp_packet_fb_get_fci_length(&pkt);
    for (guint w = 0; fci && w < words; ++w)
      n += 1 + __builtin_popcount(GST_READ_UINT16_BE(fci + 4 * w + 2));
  }
  gst_rtcp_buffer_unmap(&rtcp);
  return n;
}
GstPadProbeReturn spend_tokens(GstPad* pad, GstPadProbeInfo* info, gpointer data) {
  auto* b = static_cast<RtxBudget*>(data);
  if (!from_allowed(GST_PAD_PROBE_INFO_BUFFER(info), b->from)) {
    if (b->foreign.fetch_add(1) % 1000 == 0)
      g_printerr(
          "lf-launch: warning: %s: RTCP from a sender not in --rtcp-from dropped (%ld so "
          "far)\n",
          GST_OBJECT_NAME(GST_OBJECT_PARENT(pad)), b->foreign.load());
    return GST_PAD_PROBE_DROP;
  }
  const long n = nacked_packets(GST_PAD_PROBE_INFO_BUFFER(info));
  if (n <= 0) return GST_PAD_PROBE_OK;  // no NACK (or not RTCP: rtpsession drops it)
  if (b->milli_tokens.fetch_sub(1000 * n) >= 1000 * n) return GST_PAD_PROBE_OK;
  b->milli_tokens.fetch_add(1000 * n);
  if (b->refused.fetch_add(1) % 1000 == 0)
    g_printerr(
        "lf-launch: warning: %s: NACKs over the budget (%.0f %% of the packets sent) "
        "dropped (%ld RTCP packets so far)\n",
        GST_OBJECT_NAME(GST_OBJECT_PARENT(pad)), b->percent, b->refused.load());
  return GST_PAD_PROBE_DROP;
}

// Before an rtpjitterbuffer, a depayloader (rtpgstdepay, rtpjpegdepay) or
// an rtpsession's RTP input whose
// caps name the stream's SSRC (and "rtx-ssrc", its retransmission stream's):
// a packet of any other SSRC is dropped. The jitter buffer follows the SSRC
// of the packet it got last and starts afresh at each change, so packets
// from anyone else on the network, interleaved with the stream's, kept it
// from ever passing the stream's own (the view requests of lf-netem.sh's
// hostile run with FEC or RTX: 1 to 27 of about 140 frames composited); an
// rtpsession puts the SSRC of the first packet it sees into its output's
// caps, so a forged packet ahead of the stream took the stream's place;
// and rtpgstdepay takes in-band caps from any packet.
bool foreign_ssrc(GstBuffer* buf, guint ssrc, guint rtx_ssrc) {
  GstRTPBuffer rtp = GST_RTP_BUFFER_INIT;
  if (!gst_rtp_buffer_map(buf, GST_MAP_READ, &rtp)) return true;  // not RTP
  const guint s = gst_rtp_buffer_get_ssrc(&rtp);
  gst_rtp_buffer_unmap(&rtp);
  return s != ssrc && s != rtx_ssrc;
}
GstPadProbeReturn only_own_ssrc(GstPad* pad, GstPadProbeInfo* info, gpointer) {
  guint ssrc = 0, rtx = 0;
  if (!caps_uint(pad, "ssrc", &ssrc)) return GST_PAD_PROBE_OK;
  if (!caps_uint(pad, "rtx-ssrc", &rtx)) rtx = ssrc;
  if (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER)
    return foreign_ssrc(GST_PAD_PROBE_INFO_BUFFER(info), ssrc, rtx) ? GST_PAD_PROBE_DROP
                                                                    : GST_PAD_PROBE_OK;
  GstBufferList* list = gst_buffer_list_make_writable(GST_PAD_PROBE_INFO_BUFFER_LIST(info));
  for (guint i = gst_buffer_list_length(list); i-- > 0;)
    if (foreign_ssrc(gst_buffer_list_get(list, i), ssrc, rtx)) gst_buffer_list_remove(list, i, 1);
  GST_PAD_PROBE_INFO_DATA(info) = list;
  return gst_buffer_list_length(list) ? GST_PAD_PROBE_OK : GST_PAD_PROBE_DROP;
}

// The probes above: before every rtpjitterbuffer, depayloader and
// rtpsession's RTP input (only_own_ssrc), on every rtprtxreceive (add_ssrc),
// on every sending rtpsession (its budget) and on every udpsrc (plain RTP's
// sequence check, launch_guard.h).
void guard_rtp(GstElement* pipeline, double budget_percent,
               const std::vector<std::string>& rtcp_from) {
  for_each_element(pipeline, [budget_percent, &rtcp_from](GstElement* e, const char* kind) {
    // rtpsession's pads are request pads, made while the description was parsed.
    const char* rtp_in = g_str_equal(kind, "rtpjitterbuffer") || g_str_equal(kind, "rtpgstdepay") ||
                                 g_str_equal(kind, "rtpjpegdepay")
                             ? "sink"
                         : g_str_equal(kind, "rtpsession") ? "recv_rtp_sink"
                                                           : nullptr;
    if (GstPad* in = rtp_in ? gst_element_get_static_pad(e, rtp_in) : nullptr) {
      gst_pad_add_probe(in, kBufferProbes, only_own_ssrc, nullptr, nullptr);
      gst_object_unref(in);
    }
    if (g_str_equal(kind, "udpsrc"))  // plain RTP's sequence check (launch_guard.h)
      if (GstPad* src = gst_element_get_static_pad(e, "src")) {
        guard_plain_rtp(src);
        gst_object_unref(src);
      }
    if (g_str_equal(kind, "rtprtxreceive")) {
      GstPad* src = gst_element_get_static_pad(e, "src");
      gst_pad_add_probe(src, GST_PAD_PROBE_TYPE_EVENT_UPSTREAM, add_ssrc, nullptr, nullptr);
      gst_object_unref(src);
    } else if (g_str_equal(kind, "rtpsession")) {
      GstPad* rtp = gst_element_get_static_pad(e, "send_rtp_sink");
      GstPad* rtcp = gst_element_get_static_pad(e, "recv_rtcp_sink");
      if (rtp && rtcp) {
        auto* b = new RtxBudget;
        b->percent = budget_percent;
        for (const std::string& a : rtcp_from)
          b->from.push_back(g_inet_address_new_from_string(a.c_str()));
        gst_pad_add_probe(rtp, kBufferProbes, count_packet, b, nullptr);
        gst_pad_add_probe(rtcp, GST_PAD_PROBE_TYPE_BUFFER, spend_tokens, b,
                          [](gpointer d) { delete static_cast<RtxBudget*>(d); });
      }
      if (rtp) gst_object_unref(rtp);
      if (rtcp) gst_object_unref(rtcp);
    }
  });
}

// Every srtpenc encrypts under a key of this start, and every srtpdec
// follows its senders' keys and restarts (launch_srtp.h).
void guard_srtp(GstElement* pipeline) {
  for_each_element(pipeline, [](GstElement* e, const char* kind) {
    if (g_str_equal(kind, "srtpdec")) guard_srtp_dec(e);
    if (g_str_equal(kind, "srtpenc")) key_srtp_enc(e);
  });
}

}  // namespace

int main(int argc, char** argv) {
  gint port = 0;
  gchar* client_opt = nullptr;
  gchar* base_opt = nullptr;
  gdouble sync_timeout = 10, duration = -1, max_round_trip_ms = 0, settle = 0, poll_ms = 10;
  gboolean check = FALSE;
  gdouble rtx_budget = 25;
  gchar* rtcp_from_opt = nullptr;
  gchar* pt_clock_opt = nullptr;
  gchar** rest = nullptr;
  const GOptionEntry entries[] = {
      {"clock-server", 0, 0, G_OPTION_ARG_INT, &port,
       "Publish this machine's clock (GstNetTimeProvider) on UDP PORT", "PORT"},
      {"clock-client", 0, 0, G_OPTION_ARG_STRING, &client_opt,
       "Slave to a provider (GstNetClientClock); waits until synchronised", "HOST:PORT"},
      {"base-time", 0, 0, G_OPTION_ARG_STRING, &base_opt,
       "Base time shared by every host, ns on the shared clock; now+MS (server): now + MS "
       "milliseconds, printed as \"base-time NS\" (default now+500)",
       "NS|now+MS"},
      {"sync-timeout", 0, 0, G_OPTION_ARG_DOUBLE, &sync_timeout,
       "Client: give up if not synchronised after S seconds (default 10)", "S"},
      {"clock-settle", 0, 0, G_OPTION_ARG_DOUBLE, &settle,
       "With --check-clock: let the clock run S seconds after sync before reading it (default 0)",
       "S"},
      {"max-round-trip", 0, 0, G_OPTION_ARG_DOUBLE, &max_round_trip_ms,
       "Client: clock observations with a longer round trip are dropped (default 0: none, "
       "GstNetClientClock's own filtering only). An observation can be off by half its round "
       "trip, and a clock synchronised on a delayed one corrects itself only slowly "
       "(GstNetClientClock clamps each step to a quarter of the average round trip); too small "
       "a limit on a busy host delays synchronisation",
       "MS"},
      {"clock-poll", 0, 0, G_OPTION_ARG_DOUBLE, &poll_ms,
       "Client: ask the provider at most every MS milliseconds (GstNetClientClock's "
       "minimum-update-interval; GStreamer's default is 50). The clock is synchronised after its "
       "4th observation, so this sets how soon a (re)started host runs; once synchronised, the "
       "clock asks about once a second (default 10)",
       "MS"},
      {"duration", 0, 0, G_OPTION_ARG_DOUBLE, &duration,
       "Stop after S seconds (default: run to end of stream)", "S"},
      {"check-clock", 0, 0, G_OPTION_ARG_NONE, &check,
       "Client: print \"clock-offset-ms X\" (client clock - local system clock, read between two "
       "readings of the system clock, right after sync; with --clock-settle, the median of 10 "
       "readings 100 ms apart after it) and exit without running a pipeline",
       nullptr},
      {"rtp-clock-rate", 0, 0, G_OPTION_ARG_STRING, &pt_clock_opt,
       "Answer every rtpjitterbuffer's request-pt-map for payload type PT (e.g. forward error "
       "correction packets sharing the stream) with clock rate HZ; other payload types stay "
       "unanswered and dropped (default: none answered)",
       "PT=HZ"},
      {"rtx-budget", 0, 0, G_OPTION_ARG_DOUBLE, &rtx_budget,
       "Every rtpsession that sends RTP and reads RTCP accepts NACKs for at most P percent of "
       "the packets it has sent, plus a burst of 64; RTCP packets whose NACKs would go over are "
       "dropped with a warning (default 25)",
       "P"},
      {"rtcp-from", 0, 0, G_OPTION_ARG_STRING, &rtcp_from_opt,
       "Every rtpsession that sends RTP and reads RTCP takes RTCP (NACKs) only from these IP "
       "addresses (the receivers'); packets from any other sender are dropped with a warning "
       "(default: from anyone)",
       "ADDR[,ADDR...]"},
      {G_OPTION_REMAINING, 0, 0, G_OPTION_ARG_STRING_ARRAY, &rest, nullptr, nullptr},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  GOptionContext* ctx = g_option_context_new("-- PIPELINE DESCRIPTION...");
  g_option_context_set_summary(ctx, kSummary);
  g_option_context_add_main_entries(ctx, entries, nullptr);
  g_option_context_add_group(ctx, gst_init_get_option_group());
  GError* opt_err = nullptr;
  if (!g_option_context_parse(ctx, &argc, &argv, &opt_err)) {
    std::fprintf(stderr, "lf-launch: error: %s (see --help)\n", opt_err->message);
    g_clear_error(&opt_err);
    g_option_context_free(ctx);
    return 2;
  }
  g_option_context_free(ctx);
  if (!(rtx_budget >= 0 && rtx_budget <= 100)) {
    std::fprintf(stderr, "lf-launch: error: --rtx-budget must be 0..100 percent\n");
    return 2;
  }
  std::vector<std::string> rtcp_from;
  if (rtcp_from_opt) {
    gchar** parts = g_strsplit(rtcp_from_opt, ",", -1);
    for (gchar** q = parts; *q; ++q) {
      GInetAddress* a = g_inet_address_new_from_string(*q);
      if (!a) {
        std::fprintf(stderr, "lf-launch: error: --rtcp-from: '%s' is not an IP address\n", *q);
        g_strfreev(parts);
        g_free(rtcp_from_opt);
        return 2;
      }
      g_object_unref(a);
      rtcp_from.emplace_back(*q);
    }
    g_strfreev(parts);
    g_free(rtcp_from_opt);
  }
  PtClock pt_clock;
  if (pt_clock_opt) {
    unsigned pt = 0;
    int rate = 0;
    char tail = 0;
    if (std::sscanf(pt_clock_opt, "%u=%d%c", &pt, &rate, &tail) != 2 || pt > 127 || rate <= 0) {
      std::fprintf(stderr, "lf-launch: error: --rtp-clock-rate '%s': give PT=HZ (PT 0..127)\n",
                   pt_clock_opt);
      g_free(pt_clock_opt);
      return 2;
    }
    pt_clock = {pt, rate};
    g_free(pt_clock_opt);
  }
  const std::string server_port = port > 0 ? std::to_string(port) : "";
  const std::string client = client_opt ? client_opt : "";
  const std::string base = base_opt ? base_opt : "now+500";
  std::string description;
  for (gchar** r = rest; r && *r; ++r) description += std::string(*r) + " ";
  g_free(client_opt);
  g_free(base_opt);
  g_strfreev(rest);
  if (server_port.empty() == client.empty()) {
    std::fprintf(stderr, "lf-launch: error: give exactly one of --clock-server, --clock-client\n");
    return 2;
  }
  GstClock* clock = nullptr;
  GstNetTimeProvider* provider = nullptr;
  // The pipeline, parsed and set to PAUSED (nullptr: an error, printed).
  GstElement* pipeline = nullptr;
  auto build = [&]() -> GstElement* {
    if (description.empty()) return nullptr;
    GError* err = nullptr;
    GstElement* p = gst_parse_launch(description.c_str(), &err);
    if (!p || err) {  // a missing element too: never run half a pipeline
      std::fprintf(stderr, "lf-launch: error: %s\n", err ? err->message : "bad description");
      g_clear_error(&err);
      if (p) gst_object_unref(p);
      return nullptr;
    }
    if (pt_clock.rate > 0) answer_pt_maps(p, &pt_clock);
    guard_rtp(p, rtx_budget, rtcp_from);
    guard_srtp(p);
    // A failure here is posted on the bus and reported below.
    gst_element_set_state(p, GST_STATE_PAUSED);
    return p;
  };
  if (!server_port.empty()) {
    clock = gst_system_clock_obtain();
    provider = gst_net_time_provider_new(clock, nullptr, std::stoi(server_port));
    if (!provider) {
      std::fprintf(stderr, "lf-launch: error: cannot publish the clock on UDP port %s\n",
                   server_port.c_str());
      return 1;
    }
  } else {
    const auto colon = client.rfind(':');
    if (colon == std::string::npos) {
      std::fprintf(stderr, "lf-launch: error: --clock-client needs HOST:PORT\n");
      return 2;
    }
    clock = gst_net_client_clock_new("lf-net-clock", client.substr(0, colon).c_str(),
                                     std::stoi(client.substr(colon + 1)), 0);
    if (max_round_trip_ms > 0)
      g_object_set(clock, "round-trip-limit", static_cast<guint64>(max_round_trip_ms * GST_MSECOND),
                   nullptr);
    if (poll_ms > 0)
      g_object_set(clock, "minimum-update-interval", static_cast<guint64>(poll_ms * GST_MSECOND),
                   nullptr);
    // While the clock synchronises, the pipeline starts up to PAUSED (a live
    // pipeline's sources open their inputs there, e.g. lfcamsrc decodes its
    // stills): a restarted camera host is back sooner.
    if (!check && !(pipeline = build()) && !description.empty()) return 1;
    if (!gst_clock_wait_for_sync(clock, static_cast<GstClockTime>(sync_timeout * GST_SECOND))) {
      std::fprintf(stderr, "lf-launch: error: clock %s not synchronised after %.0f s\n",
                   client.c_str(), sync_timeout);
      if (pipeline) gst_element_set_state(pipeline, GST_STATE_NULL), gst_object_unref(pipeline);
      return 1;
    }
    if (check) {
      // Right at sync the clock has a rate fitted to a few observations;
      // on a busy machine it drifts by several ms over the next second
      // until more observations come. With --clock-settle S the clock runs
      // S seconds first (as a camera host does before its first capture
      // instant), then the median of 10 readings 100 ms apart says how far
      // it agrees; without, one reading right at sync. A reading preempted
      // between the system clock's two readings (> 1 ms apart) is taken
      // again.
      const size_t readings = settle > 0 ? 10 : 1;
      g_usleep(static_cast<gulong>(settle * G_USEC_PER_SEC));
      GstClock* sys = gst_system_clock_obtain();
      std::vector<double> offs;
      for (int tries = 0; offs.size() < readings && tries < 100; ++tries) {
        const GstClockTime a = gst_clock_get_time(sys);
        const GstClockTime c = gst_clock_get_time(clock);
        const GstClockTime b = gst_clock_get_time(sys);
        if (b - a <= GST_MSECOND) {
          offs.push_back((static_cast<double>(c) - (static_cast<double>(a) + b) / 2) / 1e6);
          if (offs.size() < readings) g_usleep(100000);
        }
      }
      if (offs.empty()) {
        std::fprintf(stderr, "lf-launch: error: no clock reading without preemption\n");
        return 1;
      }
      std::sort(offs.begin(), offs.end());
      std::printf("clock-offset-ms %.3f\n", offs[offs.size() / 2]);
      gst_object_unref(sys);
      gst_object_unref(clock);
      return 0;
    }
  }
  GstClockTime base_time;
  try {
    base_time = parse_base(base, clock);
  } catch (const std::exception&) {
    std::fprintf(stderr, "lf-launch: error: --base-time '%s' is not NS or now+MS\n", base.c_str());
    return 2;
  }
  std::printf("base-time %" G_GUINT64_FORMAT "\n", base_time);
  std::fflush(stdout);
  if (description.empty()) {
    std::fprintf(stderr, "lf-launch: error: no pipeline description after --\n");
    return 2;
  }
  if (!pipeline && !(pipeline = build())) return 1;
  // Same clock and base time everywhere; never redistribute the base time.
  gst_pipeline_use_clock(GST_PIPELINE(pipeline), clock);
  gst_element_set_start_time(pipeline, GST_CLOCK_TIME_NONE);
  gst_element_set_base_time(pipeline, base_time);
  gst_element_set_state(pipeline, GST_STATE_PLAYING);
  GstBus* bus = gst_element_get_bus(pipeline);
  int rc = 0;
  const GstClockTime timeout =
      duration >= 0 ? static_cast<GstClockTime>(duration * GST_SECOND) : GST_CLOCK_TIME_NONE;
  GstMessage* msg = gst_bus_timed_pop_filtered(
      bus, timeout, static_cast<GstMessageType>(GST_MESSAGE_EOS | GST_MESSAGE_ERROR));
  if (msg && GST_MESSAGE_TYPE(msg) == GST_MESSAGE_ERROR) {
    GError* e = nullptr;
    gchar* dbg = nullptr;
    gst_message_parse_error(msg, &e, &dbg);
    std::fprintf(stderr, "lf-launch: error from %s: %s\n%s\n", GST_OBJECT_NAME(msg->src),
                 e->message, dbg ? dbg : "");
    g_clear_error(&e);
    g_free(dbg);
    rc = 1;
  }
  if (msg) gst_message_unref(msg);
  gst_element_set_state(pipeline, GST_STATE_NULL);
  gst_object_unref(bus);
  gst_object_unref(pipeline);
  if (provider) gst_object_unref(provider);
  gst_object_unref(clock);
  return rc;
}
