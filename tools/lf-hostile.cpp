// lf-hostile: an attacker on the camera network, for soak tests of the
// distributed deployment (pipelines/net-host.sh, tools/lf-netem.sh hostile).
// At --rate packets per second it sends, in a seeded random mix:
//   random   random UDP datagrams (1..1400 bytes) straight to a port;
//   garbage  random payloads (1..2000 bytes, 1 in 50 up to 256 KiB) through
//            rtpgstpay, so they reach the depayloader and then our parsers;
//   request  view requests with hostile fields and a valid CRC: sizes up to
//            16384 x 16384, NaN/inf/huge numbers, sequences near 2^63,
//            other viewers' ids, non-rotations, degenerate focal planes;
//   fragment fragments with hostile headers and a valid CRC: huge output
//            sizes, rectangles outside the frame, lying payload sizes,
//            unknown encodings, huge or near sequences, real and unknown
//            camera ids, random or truncated payloads;
//   flipped  valid requests and fragments with a few bits flipped (CRC left
//            as it was, or recomputed over the flipped bytes);
//   caps     new caps announced in band through rtpgstpay (other sizes and
//            frame rates), as a spoofing sender could;
//   nack     with --nacks, every other packet: an RTCP receiver report and a
//            generic NACK (RFC 4585) naming 100 runs of 17 packets of the
//            given stream, to make a camera host that resends lost packets
//            (net-host.sh RTX=1) resend its history.
// A target given as HOST:PORT/SSRC gets its RTP packets with that SSRC, the
// stream's real one (net-host.sh's fixed SSRCs: requests 4096, camera host
// K's fragments 8192 + K, video 12288), as an attacker who has seen one
// packet of the stream would send them; without it, rtpgstpay's random SSRC.
// With --follow GROUP:PORT it reads the view requests in their multicast
// group, as anyone on the camera network can, and aims three in four forged
// sequences just ahead of the newest (+1..+10, +3, +4000): the request
// window's and the RTP sequence check's cases (docs/reliability.md).
// Counts per kind are printed at the end ("sent KIND N").
#include <gio/gio.h>
#include <gst/app/gstappsrc.h>
#include <gst/gst.h>
#include <libdeflate.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "lf/io/parse.h"
#include "lf/wire/wire.h"

namespace {

struct Target {
  std::string host;
  int port = 0;
  int64_t ssrc = -1;  // the RTP packets' SSRC (-1: rtpgstpay's random one)
};

bool parse_target(const char* s, Target* t) {
  const std::string str = s;
  const auto colon = str.rfind(':');
  if (colon == std::string::npos || colon == 0) return false;
  t->host = str.substr(0, colon);
  t->port = std::atoi(str.c_str() + colon + 1);
  return t->port > 0 && t->port < 65536;
}

// HOST:PORT:SSRC of --nacks.
bool parse_nack_target(const char* s, Target* t, uint32_t* ssrc) {
  const char* colon = std::strrchr(s, ':');
  if (!colon) return false;
  char* end = nullptr;
  const unsigned long v = std::strtoul(colon + 1, &end, 10);
  if (end == colon + 1 || *end || v > 0xffffffffUL) return false;
  *ssrc = static_cast<uint32_t>(v);
  return parse_target(std::string(s, colon).c_str(), t);
}

// HOST:PORT[/SSRC] of --requests and --fragments.
bool parse_rtp_target(const char* s, Target* t) {
  const char* slash = std::strchr(s, '/');
  if (!slash) return parse_target(s, t);
  char* end = nullptr;
  const unsigned long v = std::strtoul(slash + 1, &end, 10);
  if (end == slash + 1 || *end || v > 0xffffffffUL) return false;
  t->ssrc = static_cast<int64_t>(v);
  return parse_target(std::string(s, slash).c_str(), t);
}

// An appsrc ! rtpgstpay ! udpsink branch per target.
struct RtpBranch {
  GstElement* appsrc = nullptr;
  bool requests = false;
};

using Bytes = std::vector<uint8_t>;

void put_u16(Bytes& b, size_t at, uint16_t v) {
  b[at] = static_cast<uint8_t>(v >> 8);
  b[at + 1] = static_cast<uint8_t>(v);
}
void put_u32(Bytes& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<uint8_t>(v >> (24 - 8 * i));
}
void put_u64(Bytes& b, size_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) b[at + i] = static_cast<uint8_t>(v >> (56 - 8 * i));
}
void put_f64(Bytes& b, size_t at, double v) {
  uint64_t u;
  std::memcpy(&u, &v, 8);
  put_u64(b, at, u);
}
uint32_t crc_of(const Bytes& b, size_t from, size_t to) {
  return libdeflate_crc32(0, b.data() + from, to - from);
}
// The CRCs of the wire format (lib/lf/wire/wire.h), recomputed after editing.
void seal_request(Bytes& b) {
  put_u32(b, 140, crc_of(b, 0, 140));
}
void seal_fragment(Bytes& b) {
  uint32_t c = libdeflate_crc32(0, b.data(), 52);
  if (b.size() > lf::kFragmentHeaderSize)
    c = libdeflate_crc32(c, b.data() + lf::kFragmentHeaderSize, b.size() - lf::kFragmentHeaderSize);
  put_u32(b, 52, c);
}

class Attacker {
 public:
  Attacker(uint32_t seed, std::vector<int> camera_ids)
      : rng_(seed), cameras_(std::move(camera_ids)) {}

  std::mt19937_64& rng() { return rng_; }
  // An empty receiver report and a generic NACK (RTPFB, FMT 1) of `runs`
  // FCIs, each naming a random packet and the 16 after it, for `ssrc`.
  Bytes nack(uint32_t ssrc, int runs) {
    Bytes b(8 + 12 + 4 * runs);
    b[0] = 0x80, b[1] = 201;  // RR, no report blocks
    put_u16(b, 2, 1);
    put_u32(b, 4, static_cast<uint32_t>(rng_()));
    b[8] = 0x81, b[9] = 205;  // RTPFB, generic NACK
    put_u16(b, 10, static_cast<uint16_t>(2 + runs));
    put_u32(b, 12, static_cast<uint32_t>(rng_()));
    put_u32(b, 16, ssrc);
    for (int i = 0; i < runs; ++i) {
      put_u16(b, 20 + 4 * i, static_cast<uint16_t>(rng_()));
      put_u16(b, 22 + 4 * i, 0xffff);
    }
    return b;
  }
  uint64_t pick(uint64_t n) { return std::uniform_int_distribution<uint64_t>(0, n - 1)(rng_); }
  Bytes random_bytes(size_t n) {
    Bytes b(n);
    for (auto& x : b) x = static_cast<uint8_t>(rng_());
    return b;
  }
  double hostile_double() {
    static const double values[] = {std::numeric_limits<double>::quiet_NaN(),
                                    std::numeric_limits<double>::infinity(),
                                    -std::numeric_limits<double>::infinity(),
                                    1e308,
                                    -1e308,
                                    0.0,
                                    1e-308,
                                    1.0};
    return values[pick(8)];
  }
  // With a request sequence seen (--follow), three in four are just ahead
  // of it (+1..+10, +3 or +4000), as a forger would aim.
  uint64_t hostile_sequence() {
    static const uint64_t values[] = {0, 1, (1ull << 63) - 1, ~0ull, 1ull << 32};
    static const uint64_t jumps[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 3, 4000};
    if (seen_ && pick(4) != 0) return seen_ + jumps[pick(12)];
    return pick(3) == 0 ? rng_() : values[pick(5)];
  }
  // The newest request sequence seen (0: none).
  void saw(uint64_t sequence) { seen_ = std::max(seen_, sequence); }
  uint64_t seen() const { return seen_; }
  uint32_t camera_id() {
    return pick(4) == 0 ? static_cast<uint32_t>(rng_()) : cameras_[pick(cameras_.size())];
  }

  // A well-formed request (viewer, sequence, size chosen by the caller).
  Bytes valid_request(uint32_t viewer, uint64_t seq, int w, int h) {
    lf::ViewRequest r;
    r.viewer_id = viewer;
    r.sequence = seq;
    r.view.width = w;
    r.view.height = h;
    r.view.vfov_deg = 50;
    r.view.position = {0, 0, 0};
    r.focal_plane = {{0, 0, 1}, 1.0};
    return lf::serialize_request(r);
  }
  Bytes hostile_request() {
    static const int sides[] = {1, 2, 640, 4096, 16384, 65535};
    Bytes b =
        valid_request(pick(2) ? static_cast<uint32_t>(rng_()) : 0, hostile_sequence(), 640, 480);
    put_u16(b, 84, static_cast<uint16_t>(sides[pick(6)]));
    put_u16(b, 86, static_cast<uint16_t>(sides[pick(6)]));
    switch (pick(5)) {
      case 0:  // position, orientation, fov, shift, focal plane: hostile numbers
        put_f64(b, 20 + 8 * pick(15), hostile_double());
        break;
      case 1:  // a non-rotation
        for (int i = 0; i < 4; ++i) put_f64(b, 44 + 8 * i, 10.0 * i);
        break;
      case 2:  // degenerate focal plane
        for (int i = 0; i < 4; ++i) put_f64(b, 104 + 8 * i, 0.0);
        break;
      case 3:  // unknown version / size / aperture
        put_u16(b, pick(2) ? 4 : 6, static_cast<uint16_t>(rng_()));
        b[136] = static_cast<uint8_t>(rng_());
        break;
      default:  // huge sizes alone
        break;
    }
    seal_request(b);
    return b;
  }
  // A fragment whose header lies about something.
  Bytes hostile_fragment() {
    const size_t payload = pick(10) == 0 ? pick(65536) : pick(512);
    Bytes b = random_bytes(lf::kFragmentHeaderSize + payload);
    std::memcpy(b.data(), "LFFR", 4);
    put_u16(b, 4, pick(8) ? 1 : static_cast<uint16_t>(rng_()));
    put_u16(b, 6, 56);
    put_u32(b, 8, pick(2) ? 0 : static_cast<uint32_t>(rng_()));  // the real viewer, or not
    put_u64(b, 12, hostile_sequence());
    put_u32(b, 20, camera_id());
    static const uint16_t sides[] = {0, 1, 2, 640, 8192, 16384, 65535};
    put_u16(b, 32, sides[pick(7)]);
    put_u16(b, 34, sides[pick(7)]);
    for (int i = 0; i < 4; ++i) put_u16(b, 36 + 2 * i, pick(2) ? sides[pick(7)] : pick(700));
    b[44] = static_cast<uint8_t>(pick(4));  // empty, raw, jpeg, unknown
    b[45] = b[44] == 2 ? static_cast<uint8_t>(1 + pick(100)) : 0;
    put_u16(b, 46, 0);
    put_u32(b, 48, pick(3) ? static_cast<uint32_t>(payload) : static_cast<uint32_t>(rng_()));
    seal_fragment(b);
    return b;
  }
  Bytes flipped(Bytes b, bool request) {
    const int flips = 1 + static_cast<int>(pick(4));
    for (int i = 0; i < flips; ++i) b[pick(b.size())] ^= static_cast<uint8_t>(1u << pick(8));
    if (pick(2)) request ? seal_request(b) : seal_fragment(b);
    return b;
  }
  Bytes valid_fragment() {  // (the serializer refuses inconsistent fragments)
    lf::Fragment f;
    f.viewer_id = static_cast<uint32_t>(pick(3));
    f.sequence = hostile_sequence();
    f.camera_id = camera_id();
    f.out_width = 640, f.out_height = 480;
    const int w = 1 + static_cast<int>(pick(64)), h = 1 + static_cast<int>(pick(64));
    f.rect = {static_cast<int>(pick(640 - w)), static_cast<int>(pick(480 - h)), w, h};
    f.pixels = random_bytes(static_cast<size_t>(w) * h * 4);
    for (int y = 0; y < h; ++y)
      f.spans.push_back({static_cast<uint16_t>(f.rect.x), static_cast<uint16_t>(f.rect.x + w)});
    return lf::serialize_fragment(f, pick(2) ? lf::Encoding::kRaw : lf::Encoding::kJpeg, 80);
  }

 private:
  std::mt19937_64 rng_;
  std::vector<int> cameras_;
  uint64_t seen_ = 0;
};

// --follow: the view requests' multicast group, read without blocking; each
// datagram holding the start of a view request ("LFVR", wire.h) gives its
// sequence (bytes 12..19, big-endian). Only the header is read: a request
// with a focal surface spans several packets, and the attacker only aims.
struct Follower {
  GSocket* sock = nullptr;
  guint64 requests = 0;
  bool open(const std::string& group, int port) {
    GError* err = nullptr;
    GInetAddress* g = g_inet_address_new_from_string(group.c_str());
    if (!g || !g_inet_address_get_is_multicast(g)) {
      std::fprintf(stderr, "lf-hostile: error: --follow %s is not a multicast group\n",
                   group.c_str());
      if (g) g_object_unref(g);
      return false;
    }
    sock = g_socket_new(G_SOCKET_FAMILY_IPV4, G_SOCKET_TYPE_DATAGRAM, G_SOCKET_PROTOCOL_UDP, &err);
    GInetAddress* any = g_inet_address_new_any(G_SOCKET_FAMILY_IPV4);
    GSocketAddress* at = g_inet_socket_address_new(any, static_cast<guint16>(port));
    const bool ok = sock && g_socket_bind(sock, at, TRUE, &err) &&
                    g_socket_join_multicast_group(sock, g, FALSE, nullptr, &err);
    g_object_unref(at);
    g_object_unref(any);
    g_object_unref(g);
    if (!ok) {
      std::fprintf(stderr, "lf-hostile: error: --follow: %s\n", err ? err->message : "socket");
      g_clear_error(&err);
      return false;
    }
    g_socket_set_blocking(sock, FALSE);
    return true;
  }
  void read(Attacker& a) {
    if (!sock) return;
    gchar buf[2048];
    for (;;) {
      const gssize n = g_socket_receive(sock, buf, sizeof buf, nullptr, nullptr);
      if (n <= 0) return;
      const std::string d(buf, static_cast<size_t>(n));
      const size_t at = d.find("LFVR");
      if (at == std::string::npos || at + 20 > d.size()) continue;
      uint64_t seq = 0;
      for (int i = 0; i < 8; ++i) seq = seq << 8 | static_cast<uint8_t>(d[at + 12 + i]);
      a.saw(seq);
      ++requests;
    }
  }
  ~Follower() {
    if (sock) g_object_unref(sock);
  }
};

GstCaps* hostile_caps(Attacker& a, bool requests) {
  static const int sides[] = {2, 16, 320, 640, 4096, 16384};
  static const int rates[] = {1, 15, 30, 1000};
  return gst_caps_new_simple(
      requests ? "application/x-lf-view-request" : "application/x-lf-fragment", "framerate",
      GST_TYPE_FRACTION, rates[a.pick(4)], 1, "width", G_TYPE_INT, sides[a.pick(6)], "height",
      G_TYPE_INT, sides[a.pick(6)], "encoding", G_TYPE_STRING, a.pick(2) ? "raw" : "jpeg", nullptr);
}

}  // namespace

int main(int argc, char** argv) {
  gchar** request_opts = nullptr;
  gchar** fragment_opts = nullptr;
  gchar** nack_opts = nullptr;
  gchar* cameras_opt = nullptr;
  gchar* follow_opt = nullptr;
  gdouble rate = 1000, duration = 10;
  gint seed = 1;
  const GOptionEntry entries[] = {
      {"requests", 0, 0, G_OPTION_ARG_STRING_ARRAY, &request_opts,
       "Where camera hosts listen for view requests (multicast group or unicast; repeatable); "
       "/SSRC: forge that stream SSRC",
       "HOST:PORT[/SSRC]"},
      {"fragments", 0, 0, G_OPTION_ARG_STRING_ARRAY, &fragment_opts,
       "Where the compositor host listens for fragments (repeatable); /SSRC: forge that stream "
       "SSRC",
       "HOST:PORT[/SSRC]"},
      {"nacks", 0, 0, G_OPTION_ARG_STRING_ARRAY, &nack_opts,
       "Where a camera host reads RTCP NACKs, and the SSRC of its stream: every other packet "
       "is a forged NACK there (repeatable)",
       "HOST:PORT:SSRC"},
      {"rate", 0, 0, G_OPTION_ARG_DOUBLE, &rate, "Packets per second, all kinds (default 1000)",
       "HZ"},
      {"duration", 0, 0, G_OPTION_ARG_DOUBLE, &duration, "Seconds to run (default 10)", "S"},
      {"seed", 0, 0, G_OPTION_ARG_INT, &seed, "Random seed (default 1)", "N"},
      {"follow", 0, 0, G_OPTION_ARG_STRING, &follow_opt,
       "The view requests' multicast group: their sequences are read, and three in four forged "
       "requests and fragments aim just ahead (+1..+10, +3, +4000)",
       "GROUP:PORT"},
      {"camera-ids", 0, 0, G_OPTION_ARG_STRING, &cameras_opt,
       "Real camera ids to forge (comma-separated; default 0..63)", "IDS"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  GOptionContext* ctx = g_option_context_new(nullptr);
  g_option_context_set_summary(
      ctx,
      "Sends random and crafted view requests and fragments at a fixed rate, as an attacker on\n"
      "the camera network would (soak tests: tools/lf-netem.sh hostile, scripts/soak.sh).");
  g_option_context_add_main_entries(ctx, entries, nullptr);
  g_option_context_add_group(ctx, gst_init_get_option_group());
  GError* err = nullptr;
  if (!g_option_context_parse(ctx, &argc, &argv, &err)) {
    std::fprintf(stderr, "lf-hostile: error: %s (see --help)\n", err->message);
    g_clear_error(&err);
    g_option_context_free(ctx);
    return 2;
  }
  g_option_context_free(ctx);
  std::vector<std::pair<Target, bool>> targets;  // (target, is the request port)
  for (gchar** s = request_opts; s && *s; ++s) {
    Target t;
    if (!parse_rtp_target(*s, &t)) {
      std::fprintf(stderr, "lf-hostile: error: --requests %s is not HOST:PORT[/SSRC]\n", *s);
      return 2;
    }
    targets.push_back({t, true});
  }
  for (gchar** s = fragment_opts; s && *s; ++s) {
    Target t;
    if (!parse_rtp_target(*s, &t)) {
      std::fprintf(stderr, "lf-hostile: error: --fragments %s is not HOST:PORT[/SSRC]\n", *s);
      return 2;
    }
    targets.push_back({t, false});
  }
  std::vector<std::pair<Target, uint32_t>> nack_targets;
  for (gchar** s = nack_opts; s && *s; ++s) {
    Target t;
    uint32_t ssrc = 0;
    if (!parse_nack_target(*s, &t, &ssrc)) {
      std::fprintf(stderr, "lf-hostile: error: --nacks %s is not HOST:PORT:SSRC\n", *s);
      return 2;
    }
    nack_targets.push_back({t, ssrc});
  }
  g_strfreev(request_opts);
  g_strfreev(fragment_opts);
  g_strfreev(nack_opts);
  if (targets.empty() || rate <= 0 || rate > 100000 || duration <= 0) {
    std::fprintf(stderr,
                 "lf-hostile: error: give --requests and/or --fragments, 0 < --rate <= 100000, "
                 "--duration > 0\n");
    return 2;
  }
  std::vector<int> ids;
  try {
    if (cameras_opt)
      for (double v : lf::parse_number_list(cameras_opt, "--camera-ids"))
        ids.push_back(static_cast<int>(v));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-hostile: error: %s\n", e.what());
    return 2;
  }
  g_free(cameras_opt);
  if (ids.empty())
    for (int i = 0; i < 64; ++i) ids.push_back(i);

  // The RTP branches and one plain UDP socket.
  GstElement* pipe = gst_pipeline_new("hostile");
  std::vector<RtpBranch> branches;
  for (const auto& [t, req] : targets) {
    GstElement* src = gst_element_factory_make("appsrc", nullptr);
    GstElement* pay = gst_element_factory_make("rtpgstpay", nullptr);
    GstElement* sink = gst_element_factory_make("udpsink", nullptr);
    if (!src || !pay || !sink) {
      std::fprintf(stderr, "lf-hostile: error: appsrc, rtpgstpay or udpsink is missing\n");
      return 1;
    }
    GstCaps* caps = gst_caps_from_string(req ? "application/x-lf-view-request"
                                             : "application/x-lf-fragment,encoding=raw");
    g_object_set(src, "caps", caps, "format", GST_FORMAT_TIME, "is-live", TRUE, "block", FALSE,
                 "max-bytes", static_cast<guint64>(8 << 20), nullptr);
    gst_caps_unref(caps);
    g_object_set(pay, "config-interval", 1, nullptr);
    if (t.ssrc >= 0) g_object_set(pay, "ssrc", static_cast<guint>(t.ssrc), nullptr);
    g_object_set(sink, "host", t.host.c_str(), "port", t.port, "sync", FALSE, "async", FALSE,
                 "auto-multicast", TRUE, "ttl-mc", 1, "loop", FALSE,
                 nullptr);  // not heard by --follow
    gst_bin_add_many(GST_BIN(pipe), src, pay, sink, nullptr);
    gst_element_link_many(src, pay, sink, nullptr);
    branches.push_back({src, req});
  }
  if (gst_element_set_state(pipe, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE) {
    std::fprintf(stderr, "lf-hostile: error: cannot start the RTP senders\n");
    return 1;
  }
  GSocket* sock =
      g_socket_new(G_SOCKET_FAMILY_IPV4, G_SOCKET_TYPE_DATAGRAM, G_SOCKET_PROTOCOL_UDP, &err);
  if (!sock) {
    std::fprintf(stderr, "lf-hostile: error: %s\n", err->message);
    return 1;
  }
  g_socket_set_blocking(sock, FALSE);
  g_socket_set_multicast_ttl(sock, 1);
  g_socket_set_multicast_loopback(sock, FALSE);
  std::vector<GSocketAddress*> addrs;
  for (const auto& tr : targets)
    addrs.push_back(g_inet_socket_address_new_from_string(tr.first.host.c_str(), tr.first.port));
  std::vector<GSocketAddress*> nack_addrs;
  for (const auto& tr : nack_targets)
    nack_addrs.push_back(
        g_inet_socket_address_new_from_string(tr.first.host.c_str(), tr.first.port));
  for (GSocketAddress* s : addrs)
    if (!s) {
      std::fprintf(stderr, "lf-hostile: error: a target's host is not an IP address\n");
      return 2;
    }
  for (GSocketAddress* s : nack_addrs)
    if (!s) {
      std::fprintf(stderr, "lf-hostile: error: a --nacks host is not an IP address\n");
      return 2;
    }

  Attacker a(static_cast<uint32_t>(seed), ids);
  Follower follower;
  const bool following = follow_opt != nullptr;
  if (following) {
    Target f;
    const bool parsed = parse_target(follow_opt, &f);
    if (!parsed)
      std::fprintf(stderr, "lf-hostile: error: --follow %s is not GROUP:PORT\n", follow_opt);
    g_free(follow_opt);
    if (!parsed || !follower.open(f.host, f.port)) return 2;
  }
  std::map<std::string, guint64> sent;
  const gint64 start = g_get_monotonic_time();
  const double period_us = 1e6 / rate;
  guint64 n = 0;
  for (;; ++n) {
    const gint64 due = start + static_cast<gint64>(static_cast<double>(n) * period_us);
    const gint64 now = g_get_monotonic_time();
    if (now - start > static_cast<gint64>(duration * 1e6)) break;
    if (due > now) g_usleep(static_cast<gulong>(due - now));
    follower.read(a);
    if (!nack_targets.empty() && n % 2 == 1) {
      const size_t t = a.pick(nack_targets.size());
      const Bytes b = a.nack(nack_targets[t].second, 100);
      g_socket_send_to(sock, nack_addrs[t], reinterpret_cast<const gchar*>(b.data()), b.size(),
                       nullptr, nullptr);
      sent["nack"]++;
      continue;
    }
    const size_t t = a.pick(targets.size());
    const bool req = targets[t].second;
    Bytes payload;
    std::string kind;
    switch (a.pick(10)) {
      case 0:
      case 1: {
        kind = "random";
        Bytes b = a.random_bytes(1 + a.pick(1400));
        g_socket_send_to(sock, addrs[t], reinterpret_cast<const gchar*>(b.data()), b.size(),
                         nullptr, nullptr);
        break;
      }
      case 2:
      case 3:
        kind = "garbage";
        payload = a.random_bytes(1 + (a.pick(50) == 0 ? a.pick(256 << 10) : a.pick(2000)));
        break;
      case 4:
      case 5:
        kind = req ? "request" : "fragment";
        payload = req ? a.hostile_request() : a.hostile_fragment();
        break;
      case 6:
      case 7:
      case 8:
        kind = "flipped";
        payload = a.flipped(
            req ? a.valid_request(0, a.hostile_sequence(), 640, 480) : a.valid_fragment(), req);
        break;
      default: {
        kind = "caps";
        GstCaps* caps = hostile_caps(a, req);
        g_object_set(branches[t].appsrc, "caps", caps, nullptr);
        gst_caps_unref(caps);
        payload = req ? a.hostile_request() : a.hostile_fragment();
        break;
      }
    }
    if (!payload.empty()) {
      GstBuffer* buf = gst_buffer_new_memdup(payload.data(), payload.size());
      GST_BUFFER_PTS(buf) = static_cast<GstClockTime>(g_get_monotonic_time() - start) * 1000;
      gst_app_src_push_buffer(GST_APP_SRC(branches[t].appsrc), buf);
    }
    sent[kind]++;
    if (n % 10000 == 0 && n > 0)
      std::fprintf(stderr, "lf-hostile: %" G_GUINT64_FORMAT " packets, %.0f s\n", n,
                   static_cast<double>(g_get_monotonic_time() - start) / 1e6);
  }
  const double secs = static_cast<double>(g_get_monotonic_time() - start) / 1e6;
  gst_element_set_state(pipe, GST_STATE_NULL);
  gst_object_unref(pipe);
  for (GSocketAddress* s : addrs) g_object_unref(s);
  for (GSocketAddress* s : nack_addrs) g_object_unref(s);
  g_object_unref(sock);
  for (const auto& [k, v] : sent) std::printf("sent %s %" G_GUINT64_FORMAT "\n", k.c_str(), v);
  if (following)
    std::printf("followed %" G_GUINT64_FORMAT " requests, the last sequence %" G_GUINT64_FORMAT
                "\n",
                follower.requests, a.seen());
  std::printf("sent total %" G_GUINT64_FORMAT " in %.1f s (%.0f per second)\n", n, secs,
              static_cast<double>(n) / secs);
  return 0;
}
