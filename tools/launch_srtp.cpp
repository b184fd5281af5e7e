// lf-launch's SRTP handling (see launch_srtp.h).
#include "launch_srtp.h"

#include <sys/random.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

namespace {

// HMAC-SHA256(key, label || data), its first n bytes (n <= 32).
void hmac_sha256(const uint8_t* key, size_t key_len, const char* label, const uint8_t* data,
                 size_t data_len, uint8_t* out, size_t n) {
  GHmac* h = g_hmac_new(G_CHECKSUM_SHA256, key, key_len);
  g_hmac_update(h, reinterpret_cast<const guchar*>(label), std::strlen(label));
  g_hmac_update(h, data, data_len);
  uint8_t d[32];
  gsize len = sizeof d;
  g_hmac_get_digest(h, d, &len);
  g_hmac_unref(h);
  std::memcpy(out, d, std::min(n, sizeof d));
}

constexpr size_t kNonceBytes = kSrtpMkiBytes / 2;
constexpr char kMkiLabel[] = "lightfield-gst srtp mki";

}  // namespace

bool srtp_new_mki(const uint8_t* master, size_t master_len, uint8_t mki[kSrtpMkiBytes]) {
  if (getrandom(mki, kNonceBytes, 0) != static_cast<ssize_t>(kNonceBytes)) return false;
  hmac_sha256(master, master_len, kMkiLabel, mki, kNonceBytes, mki + kNonceBytes,
              kSrtpMkiBytes - kNonceBytes);
  return true;
}

bool srtp_mki_is_sessions(const uint8_t* master, size_t master_len,
                          const uint8_t mki[kSrtpMkiBytes]) {
  uint8_t tag[kSrtpMkiBytes - kNonceBytes];
  hmac_sha256(master, master_len, kMkiLabel, mki, kNonceBytes, tag, sizeof tag);
  uint8_t d = 0;  // in a time that does not depend on where they differ
  for (size_t i = 0; i < sizeof tag; ++i) d |= tag[i] ^ mki[kNonceBytes + i];
  return d == 0;
}

bool srtp_start_key(const uint8_t* master, size_t master_len, const uint8_t* mki, uint8_t* out,
                    size_t out_len) {
  if (out_len == 0 || out_len > 64 || master_len == 0) return false;
  static const char kLabel[] = "lightfield-gst srtp start";
  uint8_t t[32];
  gsize t_len = 0;
  for (size_t done = 0, block = 1; done < out_len; ++block) {
    GHmac* h = g_hmac_new(G_CHECKSUM_SHA256, master, master_len);
    if (block > 1) g_hmac_update(h, t, t_len);
    g_hmac_update(h, reinterpret_cast<const guchar*>(kLabel), sizeof kLabel - 1);
    g_hmac_update(h, mki, kSrtpMkiBytes);
    const guchar counter = static_cast<guchar>(block);
    g_hmac_update(h, &counter, 1);
    t_len = sizeof t;
    g_hmac_get_digest(h, t, &t_len);
    g_hmac_unref(h);
    const size_t n = std::min(out_len - done, static_cast<size_t>(t_len));
    std::memcpy(out + done, t, n);
    done += n;
  }
  return true;
}

void key_srtp_enc(GstElement* enc) {
  GstBuffer* master = nullptr;
  g_object_get(enc, "key", &master, nullptr);
  if (!master) return;
  GstMapInfo m;
  if (gst_buffer_map(master, &m, GST_MAP_READ)) {
    std::array<uint8_t, kSrtpMkiBytes> mki{};
    std::array<uint8_t, 64> key{};
    if (srtp_new_mki(m.data, m.size, mki.data()) &&
        srtp_start_key(m.data, m.size, mki.data(), key.data(), m.size)) {
      GstBuffer* k = gst_buffer_new_memdup(key.data(), m.size);
      GstBuffer* i = gst_buffer_new_memdup(mki.data(), mki.size());
      g_object_set(enc, "key", k, "mki", i, nullptr);
      gst_buffer_unref(k);
      gst_buffer_unref(i);
    } else {
      g_printerr("lf-launch: %s: no key of this start (no randomness, or a key of %zu bytes)\n",
                 GST_OBJECT_NAME(enc), static_cast<size_t>(m.size));
    }
    gst_buffer_unmap(master, &m);
  }
  gst_buffer_unref(master);
}

namespace {

// A sender restarted within a session starts its stream again at rollover
// counter 0, a random sequence number and a new MKI, while its receiver's
// srtpdec keeps the old stream's state: each packet is then refused (an
// MKI it has no key for, "too old" for the replay window, or the wrong
// rollover counter), and the host would never be heard again. So the
// stream's state is removed ("remove-key") when none of its packets has
// passed srtpdec for kRejoinUs and a packet carries a session MKI srtpdec
// was not given (every session's first packet, or a restart), or 8
// packets with session MKIs have failed since the last one passed (a
// replay window or rollover counter gone wrong). srtpdec then asks for the
// key at the next packet ("request-key") and gets the start keys of the
// session MKIs heard last, with rollover counter 0 (a restart) and, at the
// next removal, the counter it had (a stream paused while someone else's
// packets came), and follows whichever authenticates. Packets with a
// made-up MKI count for nothing, so forged packets without the master key
// cause no removal; a removal only forgets which packets were already
// seen, and a replayed old packet carries a request sequence that the
// compositor and the camera hosts have left behind. Another SSRC is
// refused its key (no state made for made-up SSRCs).
constexpr gint64 kRejoinUs = 250000;
constexpr size_t kMkisKept = 4;  // session MKIs followed per stream, keys given to srtpdec

struct SrtpWatch {
  GstElement* dec = nullptr;  // not owned (lives as long as the pipeline)
  GstPad* sink = nullptr;     // its rtp_sink (owned): srtpdec asks for a key
                              // holding its own lock, so no element lookup then
  std::atomic<gint64> last_out_us{0};
  std::atomic<int> failing{0};  // packets with session MKIs in since the last one out
  std::atomic<gint64> last_reset_us{0};
  std::atomic<unsigned> resets{0};
  std::atomic<guint> last_roc{0};
  using Id = std::array<uint8_t, kSrtpMkiBytes>;
  std::mutex lock;                           // guards the two below
  std::vector<std::pair<Id, gint64>> heard;  // session MKIs, when last heard (µs)
  std::vector<Id> given;                     // those whose keys srtpdec was given
};

guint stream_roc(GstElement* dec, guint ssrc) {
  GstStructure* stats = nullptr;
  g_object_get(dec, "stats", &stats, nullptr);
  guint roc = 0;
  if (stats) {
    const GValue* streams = gst_structure_get_value(stats, "streams");
    if (streams && GST_VALUE_HOLDS_ARRAY(streams))
      for (guint i = 0; i < gst_value_array_get_size(streams); ++i) {
        const GValue* v = gst_value_array_get_value(streams, i);
        guint s = 0, r = 0;
        if (GST_VALUE_HOLDS_STRUCTURE(v) &&
            gst_structure_get_uint(gst_value_get_structure(v), "ssrc", &s) && s == ssrc &&
            gst_structure_get_uint(gst_value_get_structure(v), "roc", &r))
          roc = r;
      }
    gst_structure_free(stats);
  }
  return roc;
}

// What srtpdec's caps give: the stream's SSRC, its master key and the bytes
// after the MKI (the authentication tag of srtp-auth; an AEAD cipher's tag
// is inside the encrypted part). False if the caps lack one.
struct StreamCaps {
  guint ssrc = 0;
  std::array<uint8_t, 64> master{};
  size_t master_len = 0;
  size_t tag = 0;
};
bool stream_caps(const GstCaps* caps, StreamCaps* c) {
  if (!caps || gst_caps_get_size(caps) == 0) return false;
  const GstStructure* s = gst_caps_get_structure(caps, 0);
  const GValue* kv = gst_structure_get_value(s, "srtp-key");
  GstBuffer* key = kv && G_VALUE_HOLDS(kv, GST_TYPE_BUFFER) ? gst_value_get_buffer(kv) : nullptr;
  const char* auth = gst_structure_get_string(s, "srtp-auth");
  c->tag = !auth                               ? 0
           : g_str_equal(auth, "hmac-sha1-80") ? 10
           : g_str_equal(auth, "hmac-sha1-32") ? 4
                                               : 0;
  if (!gst_structure_get_uint(s, "ssrc", &c->ssrc) || !key ||
      gst_buffer_get_size(key) > c->master.size())
    return false;
  c->master_len = gst_buffer_extract(key, 0, c->master.data(), c->master.size());
  return c->master_len == gst_buffer_get_size(key);
}

// Whether `id` is a session MKI: one heard before, or one whose tag is
// right (an HMAC only for MKIs not heard yet).
bool sessions_mki(SrtpWatch* w, const StreamCaps& c, const SrtpWatch::Id& id) {
  {
    std::lock_guard<std::mutex> l(w->lock);
    for (const auto& h : w->heard)
      if (h.first == id) return true;
  }
  return srtp_mki_is_sessions(c.master.data(), c.master_len, id.data());
}

// Notes a session MKI as heard; true if srtpdec was not given its key.
bool hear_mki(SrtpWatch* w, const SrtpWatch::Id& id, gint64 now) {
  std::lock_guard<std::mutex> l(w->lock);
  auto it =
      std::find_if(w->heard.begin(), w->heard.end(), [&](const auto& h) { return h.first == id; });
  if (it != w->heard.end()) {
    it->second = now;
  } else if (w->heard.size() < kMkisKept) {
    w->heard.emplace_back(id, now);
  } else {  // the one heard longest ago makes room
    *std::min_element(w->heard.begin(), w->heard.end(),
                      [](const auto& a, const auto& b) { return a.second < b.second; }) = {id, now};
  }
  return std::find(w->given.begin(), w->given.end(), id) == w->given.end();
}

GstPadProbeReturn srtp_in(GstPad* pad, GstPadProbeInfo* info, gpointer data) {
  auto* w = static_cast<SrtpWatch*>(data);
  StreamCaps c;
  GstCaps* caps = gst_pad_get_current_caps(pad);
  const bool known = stream_caps(caps, &c);
  if (caps) gst_caps_unref(caps);
  if (!known) return GST_PAD_PROBE_OK;
  // Only the stream's own packets count (others never get a key).
  GstBuffer* buf = (GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER)
                       ? GST_PAD_PROBE_INFO_BUFFER(info)
                       : nullptr;
  guint8 head[12];
  if (!buf || gst_buffer_extract(buf, 0, head, sizeof head) != sizeof head || (head[0] >> 6) != 2 ||
      (static_cast<guint>(head[8]) << 24 | static_cast<guint>(head[9]) << 16 |
       static_cast<guint>(head[10]) << 8 | head[11]) != c.ssrc)
    return GST_PAD_PROBE_OK;
  // Only packets with a session MKI count (a made-up one is refused by
  // srtpdec and says nothing of the sender).
  const gsize size = gst_buffer_get_size(buf);
  SrtpWatch::Id mki;
  if (size < sizeof head + kSrtpMkiBytes + c.tag ||
      gst_buffer_extract(buf, size - c.tag - kSrtpMkiBytes, mki.data(), mki.size()) != mki.size() ||
      !sessions_mki(w, c, mki))
    return GST_PAD_PROBE_OK;
  const gint64 now = g_get_monotonic_time();
  const bool unknown = hear_mki(w, mki, now);
  const int failing = w->failing.fetch_add(1) + 1;
  if (now - w->last_out_us.load() < kRejoinUs || now - w->last_reset_us.load() < kRejoinUs ||
      (failing < 8 && !unknown))
    return GST_PAD_PROBE_OK;
  w->last_reset_us = now;
  w->failing = 0;
  const unsigned n = w->resets.fetch_add(1) + 1;
  if (n % 2 == 1) w->last_roc = stream_roc(w->dec, c.ssrc);
  if (n == 2 || n % 20 == 0)  // the first is every session's start
    g_printerr(
        "lf-launch: %s: SSRC %u: none of its packets authenticated for %.0f ms while packets "
        "with its session's keys came: its SRTP state is reset (a restarted sender, or old "
        "packets replayed; %u so far)\n",
        GST_OBJECT_NAME(w->dec), c.ssrc, static_cast<double>(kRejoinUs) / 1000.0, n);
  g_signal_emit_by_name(w->dec, "remove-key", c.ssrc);
  return GST_PAD_PROBE_OK;
}

GstPadProbeReturn srtp_out(GstPad*, GstPadProbeInfo*, gpointer data) {
  auto* w = static_cast<SrtpWatch*>(data);
  w->last_out_us = g_get_monotonic_time();
  w->failing = 0;
  return GST_PAD_PROBE_OK;
}

// request-key: the caps' parameters, with the start keys of the session
// MKIs heard last in place of the master key (none heard yet: the caps'
// own key).
GstCaps* srtp_key(GstElement*, guint ssrc, gpointer data) {
  auto* w = static_cast<SrtpWatch*>(data);
  StreamCaps c;
  GstCaps* caps = gst_pad_get_current_caps(w->sink);
  if (!stream_caps(caps, &c) || c.ssrc != ssrc) {
    if (caps) gst_caps_unref(caps);
    return nullptr;
  }
  caps = gst_caps_make_writable(caps);
  GstStructure* s = gst_caps_get_structure(caps, 0);
  {
    std::lock_guard<std::mutex> l(w->lock);
    std::vector<std::pair<SrtpWatch::Id, gint64>> latest = w->heard;
    std::sort(latest.begin(), latest.end(),
              [](const auto& a, const auto& b) { return a.second > b.second; });
    w->given.clear();
    for (size_t i = 0; i < latest.size(); ++i) {
      std::vector<uint8_t> key(c.master_len);
      if (!srtp_start_key(c.master.data(), c.master_len, latest[i].first.data(), key.data(),
                          key.size()))
        continue;
      const std::string suffix = w->given.empty() ? "" : std::to_string(w->given.size() + 1);
      GstBuffer* k = gst_buffer_new_memdup(key.data(), key.size());
      GstBuffer* id = gst_buffer_new_memdup(latest[i].first.data(), kSrtpMkiBytes);
      gst_structure_set(s, ("srtp-key" + suffix).c_str(), GST_TYPE_BUFFER, k,
                        ("mki" + suffix).c_str(), GST_TYPE_BUFFER, id, nullptr);
      gst_buffer_unref(k);
      gst_buffer_unref(id);
      w->given.push_back(latest[i].first);
    }
  }
  const guint roc = w->resets.load() % 2 == 1 ? 0 : w->last_roc.load();
  gst_structure_set(s, "roc", G_TYPE_UINT, roc, nullptr);
  return caps;
}

}  // namespace

void guard_srtp_dec(GstElement* e) {
  GstPad* in = gst_element_get_static_pad(e, "rtp_sink");
  GstPad* out = gst_element_get_static_pad(e, "rtp_src");
  if (in && out) {
    auto* w = new SrtpWatch;
    w->dec = e;
    w->sink = GST_PAD(gst_object_ref(in));
    gst_pad_add_probe(in, GST_PAD_PROBE_TYPE_BUFFER, srtp_in, w, [](gpointer d) {
      auto* w = static_cast<SrtpWatch*>(d);
      gst_object_unref(w->sink);
      delete w;
    });
    gst_pad_add_probe(
        out,
        static_cast<GstPadProbeType>(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST),
        srtp_out, w, nullptr);
    g_signal_connect(e, "request-key", G_CALLBACK(srtp_key), w);
  }
  if (in) gst_object_unref(in);
  if (out) gst_object_unref(out);
}
