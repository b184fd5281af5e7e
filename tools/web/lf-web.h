// lf-web's shared parts (tools/lf-web.cpp: the server and its viewers;
// tools/web/signalling.cpp: SDP and ICE with a browser;
// tools/web/control.cpp: the view control protocol on the data channel;
// tools/web/whep.cpp: WHEP): the limits on what a browser may send, the
// options, a viewer's state and the functions the parts call in one
// another. Everything from a browser is hostile (see tools/lf-web.cpp).
#pragma once

#include <gio/gio.h>
#include <glib-unix.h>
#include <glib/gstdio.h>
#include <gst/gst.h>
#include <gst/sdp/sdp.h>
#include <gst/video/navigation.h>
#define GST_USE_UNSTABLE_API
#include <gst/webrtc/webrtc.h>
#include <libsoup/soup.h>
#include <malloc.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "cli.h"
#include "lf/geometry/view.h"
#include "lf/io/datasets.h"
#include "lf/io/rig_file.h"
#include "lfevents.h"
#include "lfrate.h"
#include "lfviewprops.h"

namespace lfweb {

using json = nlohmann::json;

// Limits on what a browser may send.
constexpr gsize kMaxSignalBytes = 64 * 1024;  // one WebSocket message (an SDP answer)
constexpr size_t kMaxControlBytes = 4096;     // one data channel message
constexpr int kMaxIceCandidates = 64;         // per browser
constexpr double kControlRate = 60;           // messages per second, sustained and in a burst

struct Options {
  std::string rig_path;  // the rig file the elements read
  int width = 640, height = 480, fps = 15;
  int port = 8080;
  std::string address = "0.0.0.0";
  int bitrate_kbps = 1500;
  int max_viewers = 8;
  int max_per_address = 4;  // viewers from one remote address
  int handshake_s = 10;     // an offer unanswered or ICE unconnected this long frees the slot
  int latency_ms = 200;
  std::string token;                      // required in /ws?token=... when set
  std::vector<std::string> allow_origin;  // Origins besides the page's own; "*": any
  std::string stun;
  std::string source;  // the camera source's bin description
  bool quiet = false;
  double spacing = 1, fx = 1;  // the rig's camera spacing, focal length (px)
  size_t cameras = 0;
};

// A control channel's message limit: the collection's token bucket
// (gst/lfrate.h: kControlRate a second, bursts of one second's worth),
// shared by the signalling and data channel threads.
class RateLimit {
 public:
  bool take() {
    std::lock_guard<std::mutex> l(m_);
    return bucket_.take(kControlRate, g_get_monotonic_time());
  }
  // True at most once a second (for warnings about a flood).
  bool may_warn() {
    std::lock_guard<std::mutex> l(m_);
    const gint64 now = g_get_monotonic_time();
    if (now - warned_ < G_USEC_PER_SEC) return false;
    warned_ = now;
    return true;
  }

 private:
  std::mutex m_;
  lfgst::TokenBucket bucket_;
  gint64 warned_ = 0;
};

struct Server;

// The part of a viewer that the webrtcbin and data channel callbacks (on
// GStreamer's threads) reach; shared, so a callback in flight while the
// viewer is removed still finds it valid.
struct Control {
  Server* server = nullptr;
  guint64 serial = 0;                // unique for the server's life (viewer ids are reused)
  guint viewer_id = 0;               // lfviewrequest viewer-id (stereo: + 1 for the right eye)
  GstElement* request = nullptr;     // lfviewrequest (ref)
  GstElement* compositor = nullptr;  // lfcompositor (ref)
  json rate;  // its last lf-rate message in JSON form (null before the first; main loop only)
  GstElement* webrtc = nullptr;  // webrtcbin (ref)
  std::mutex channel_lock;
  GstWebRTCDataChannel* channel = nullptr;  // (ref) open data channel, or null
  RateLimit limit;
  std::atomic<guint64> messages{0}, refused{0};
  std::atomic<bool> stereo{false};
  std::atomic<bool> connected{false};    // ICE connected (the handshake deadline's test)
  std::atomic<gint64> offered_us{0};     // when our offer went out (monotonic µs; 0: not yet)
  std::atomic<bool> offer_taken{false};  // an offer was made and is going out
  std::atomic<bool> negotiation_needed{false};  // webrtcbin emitted on-negotiation-needed
  int offers_asked = 0;  // offers asked for by the deadline, not webrtcbin (main loop only)
  ~Control() {
    if (channel) g_object_unref(channel);
    if (request) gst_object_unref(request);
    if (compositor) gst_object_unref(compositor);
    if (webrtc) gst_object_unref(webrtc);
  }
  void send(const json& j) {
    std::lock_guard<std::mutex> l(channel_lock);
    if (channel) gst_webrtc_data_channel_send_string(channel, j.dump().c_str());
  }
};

struct Viewer {
  std::shared_ptr<Control> ctl;
  SoupWebsocketConnection* ws = nullptr;  // (ref)
  GstElement* bin = nullptr;              // in the pipeline
  GstPad* mux_pad = nullptr;              // requests in (ref)
  GstPad* demux_pads[2] = {nullptr, nullptr};
  GstWebRTCDataChannel* channel = nullptr;  // (ref) the control channel we made, for its handlers
  std::string address;                      // the browser's IP address
  guint deadline = 0;                       // the handshake deadline's GSource id (0: gone)
  bool answered = false;
  gint64 built_us = 0;  // when the branch was built (monotonic µs)
  int candidates = 0;
  // WHEP (no WebSocket): the POST waiting for its SDP answer (ref; null
  // once answered), and the timer that answers with what ICE has gathered.
  SoupServerMessage* whep_post = nullptr;
  guint whep_timer = 0;
};

struct Server {
  Options opt;
  GMainLoop* loop = nullptr;
  GstElement* pipeline = nullptr;
  GstElement* mux = nullptr;
  GstElement* demux = nullptr;
  SoupServer* soup = nullptr;
  GSocketService* service = nullptr;  // accepts for soup (tools/web/http.cpp listen_on)
  std::map<guint64, std::unique_ptr<Viewer>> viewers;  // by serial (main thread only)
  guint64 next_serial = 1;
  int exit_code = 0;
};

using ControlRef = std::shared_ptr<Control>;
inline gpointer new_ref(const ControlRef& c) {
  return new ControlRef(c);
}
inline const ControlRef& ref_of(gpointer data) {
  return *static_cast<ControlRef*>(data);
}
inline void delete_ref(gpointer data) {
  delete static_cast<ControlRef*>(data);
}
inline void delete_ref_closure(gpointer data, GClosure*) {
  delete_ref(data);
}

// tools/lf-web.cpp
void say(const Server* s, const char* fmt, ...) G_GNUC_PRINTF(2, 3);
void refuse(Control& c, const std::string& why);
void post(Control& c, std::string text);
void remove_viewer(Server* s, guint64 serial, const char* why);
// Handles the pipeline bus's queued messages now, up to kBusDrain of them
// (on_bus): see there.
void drain_bus(Server* s);
std::unique_ptr<Viewer> build_viewer(Server* s, const std::string& address, bool own_channel);
bool add_viewer(Server* s, SoupWebsocketConnection* ws, const std::string& address);
void on_ws_closed(SoupWebsocketConnection*, gpointer data);
// The handshake deadline of a viewer (tools/lf-web.cpp on_deadline).
struct Deadline {
  Server* server;
  guint64 serial;
};
gboolean on_deadline(gpointer data);

// tools/web/signalling.cpp: WebRTC signalling with a browser (SDP and ICE
// over the WebSocket).
void on_offer(GstPromise* promise, gpointer data);
void on_negotiation_needed(GstElement* webrtc, gpointer data);
// Asks webrtcbin for an offer (create-offer); the first offer made goes
// out, any later one is dropped (Control::offer_taken).
void ask_offer(const ControlRef& ctl);
void on_ice_candidate(GstElement*, guint mline, gchar* candidate, gpointer data);
void on_ice_state(GstElement* webrtc, GParamSpec*, gpointer data);
void on_ws_message(SoupWebsocketConnection*, gint type, GBytes* message, gpointer data);

// tools/web/control.cpp: the view control protocol (docs/web.md), one
// message at a time, and the data channel it comes on.
std::string apply_control(Control& c, const json& j);
// A structure of the codec (gst/lfevents.h) in its JSON form: {"type": its
// name, field: value, ...}; numbers, booleans and strings (other fields
// are left out).
json structure_json(const GstStructure* s);
// Every field of `j` one of `known`, else an error in *err.
bool only_fields(const json& j, std::initializer_list<const char*> known, std::string* err);
void on_channel_open(GstWebRTCDataChannel* ch, gpointer data);
void on_control_message(GstWebRTCDataChannel*, gchar* text, gpointer data);
void on_control_bytes(GstWebRTCDataChannel*, GBytes*, gpointer data);
void connect_channel(GstWebRTCDataChannel* ch, const ControlRef& ctl);
void release_channel(GstWebRTCDataChannel* ch);

// tools/web/http.cpp: who may connect (a refusal's reason and status, or
// ""), the WebSocket's gate and upgrade, the page.
std::string refusal(const Server* s, SoupServerMessage* msg, const char* token, guint* status);
bool same_secret(const std::string& a, const std::string& b);
void on_ws_gate(SoupServer*, SoupServerMessage* msg, const char*, GHashTable* query, gpointer data);
void on_websocket(SoupServer*, SoupServerMessage* msg, const char*, SoupWebsocketConnection* ws,
                  gpointer data);
void on_http(SoupServer*, SoupServerMessage* msg, const char* path, GHashTable*, gpointer);
// Listens on `address` (port 0: one the system picks, returned in *port),
// accepting connections for s->soup; stop_listening closes it.
bool listen_on(Server* s, GSocketAddress* address, int* port, GError** err);
void stop_listening(Server* s);

// tools/web/whep.cpp: WHEP (RFC 9725).
void on_remote_channel(GstElement*, GstWebRTCDataChannel* ch, gpointer data);
void on_gathering(GstElement* webrtc, GParamSpec*, gpointer data);
void on_whep(SoupServer* server, SoupServerMessage* msg, const char* path, GHashTable* query,
             gpointer data);

}  // namespace lfweb
