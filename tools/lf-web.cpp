// lf-web: serves the live light field to web browsers over WebRTC. Every
// browser is a viewer with its own virtual camera (paper, Section 1:
// "multiple viewers navigate virtual cameras"): its own lfviewrequest,
// lfcompositor, VP8 encoder and webrtcbin, while the cameras are shared
// (lfrequestmux -> camera source -> lffragmentdemux, one mux and one demux
// pad per viewer).
//
// One HTTP port (libsoup 3): GET / is the viewer page (tools/web/, compiled
// into the binary as a GResource), /ws the signalling WebSocket (SDP offer
// from the server, answer and ICE candidates from the browser, JSON). View
// control travels on a WebRTC data channel ("control") beside the video:
// protocol in tools/web/viewer.js and docs/web.md. Everything from a browser is
// hostile: bounded message sizes and rates, every field checked, a bad
// message refused with a warning to that browser and on stderr, never an
// effect on another viewer.
#include "web/lf-web.h"

#include "lf-web-resources.h"  // the page (glib-compile-resources): registered in main

namespace lfweb {

void say(const Server* s, const char* fmt, ...) {
  if (s->opt.quiet) return;
  va_list ap;
  va_start(ap, fmt);
  gchar* m = g_strdup_vprintf(fmt, ap);
  va_end(ap);
  std::fprintf(stdout, "lf-web: %s\n", m);
  std::fflush(stdout);
  g_free(m);
}

// A refused message: a warning on stderr and to the browser, at most one a
// second each (a flood must not become a flood of warnings).
void refuse(Control& c, const std::string& why) {
  c.refused++;
  if (!c.limit.may_warn()) return;
  std::fprintf(stderr, "lf-web: warning: viewer %u: %s (%llu refused so far)\n", c.viewer_id,
               why.c_str(), static_cast<unsigned long long>(c.refused.load()));
  c.send({{"type", "warning"}, {"message", why}});
}

// ---- messages from GStreamer's threads to the main thread ----------------

struct Post {
  Server* server;
  guint64 serial;
  std::string text;  // for the WebSocket; empty: remove the viewer
};

gboolean deliver(gpointer data) {
  std::unique_ptr<Post> p(static_cast<Post*>(data));
  auto it = p->server->viewers.find(p->serial);
  if (it == p->server->viewers.end()) return G_SOURCE_REMOVE;
  if (p->text.empty()) {
    remove_viewer(p->server, p->serial, "its connection failed");
  } else if (it->second->ws &&
             soup_websocket_connection_get_state(it->second->ws) == SOUP_WEBSOCKET_STATE_OPEN) {
    soup_websocket_connection_send_text(it->second->ws, p->text.c_str());
  }
  return G_SOURCE_REMOVE;
}

void post(Control& c, std::string text) {
  g_main_context_invoke(nullptr, deliver, new Post{c.server, c.serial, std::move(text)});
}

// ---- viewers (the view control protocol: tools/web/control.cpp) ---------

// The smallest even viewer id in use by nobody (id + 1 is its right eye).
guint free_viewer_id(const Server* s) {
  std::set<guint> used;
  for (const auto& v : s->viewers) used.insert(v.second->ctl->viewer_id);
  guint id = 0;
  while (used.count(id)) id += 2;
  return id;
}

std::string viewer_description(const Options& o, guint id) {
  const std::string rig = "rig=\"" + o.rig_path + "\"";
  std::string d = "lfviewrequest name=req " + rig + " viewer-id=" + std::to_string(id) +
                  " is-live=true framerate=" + std::to_string(o.fps) +
                  "/1 width=" + std::to_string(o.width) + " height=" + std::to_string(o.height);
  // Fragments of the left and right eye (the right only in stereo); queues
  // bounded in time, so a slow viewer drops its own fragments, not others'.
  for (const char* q : {"ql", "qr"})
    d += std::string(" queue name=") + q +
         " max-size-buffers=0 max-size-bytes=0 max-size-time=" + std::to_string(2 * o.latency_ms) +
         "000000 leaky=downstream ! comp.";
  d += " lfcompositor name=comp " + rig + " viewer-id=" + std::to_string(id) +
       " latency=" + std::to_string(o.latency_ms) +
       "000000 ! videoconvert ! queue max-size-buffers=2 "
       "max-size-bytes=0 max-size-time=0 leaky=downstream ! vp8enc deadline=1 cpu-used=8 "
       "lag-in-frames=0 error-resilient=partitions keyframe-max-dist=" +
       std::to_string(2 * o.fps) + " target-bitrate=" + std::to_string(o.bitrate_kbps * 1000) +
       " ! rtpvp8pay picture-id-mode=15-bit mtu=1200 ! "
       "application/x-rtp,media=video,encoding-name=VP8,"
       "payload=96,clock-rate=90000 ! webrtcbin name=webrtc bundle-policy=max-bundle";
  if (!o.stun.empty()) d += " stun-server=" + o.stun;
  return d;
}

GstPad* ghost(GstElement* bin, const char* child, const char* pad, const char* name) {
  GstElement* e = gst_bin_get_by_name(GST_BIN(bin), child);
  GstPad* target = gst_element_get_static_pad(e, pad);
  GstPad* g = gst_ghost_pad_new(name, target);
  gst_object_unref(target);
  gst_object_unref(e);
  gst_pad_set_active(g, TRUE);
  gst_element_add_pad(bin, g);
  return g;
}

// The handshake deadline: a browser that has not answered the offer and
// connected (ICE) within --handshake-timeout seconds of the offer loses its
// slot, so connections that never answer cannot hold the viewers for ever.
// The time is the browser's: it counts from our offer, not from the
// connection (webrtcbin makes its offer, a DTLS key included, in a fraction
// of a second, but on a loaded machine it can take seconds: the likeliest
// reason a CI run's lifetime test, with a 3-s deadline, saw a connection
// closed before its offer). Our own part is bounded too: no offer within
// kOfferBoundS of the connection drops the viewer.
//
// The offer is asked for when webrtcbin emits on-negotiation-needed, which
// it does once caps reach its sink pads, i.e. with the viewer's first
// frame. A viewer without frames never had one: every viewer, once
// lffragmentdemux let a viewer's arrival stop the cameras' stream (fixed;
// the likeliest cause of a lifetime test that once waited 20 s for an
// offer in CI, not proven). So the deadline
// asks again itself, every kOfferRetryS while none has gone out, at most
// kOfferAsks times; the first offer made goes out, a later one is dropped.

constexpr gint64 kOfferBoundS = 30;
constexpr gint64 kOfferRetryS = 2;
// Bus messages handled at most in one go (drain_bus).
constexpr int kBusDrain = 4096;
constexpr int kOfferAsks = 3;

// The viewer's deadline timer, `ms` from now.
guint arm_deadline(Server* s, guint64 serial, gint64 ms) {
  return g_timeout_add_full(G_PRIORITY_DEFAULT, static_cast<guint>(ms), on_deadline,
                            new Deadline{s, serial},
                            [](gpointer d) { delete static_cast<Deadline*>(d); });
}

gboolean on_deadline(gpointer data) {
  const auto* d = static_cast<const Deadline*>(data);
  auto it = d->server->viewers.find(d->serial);
  if (it == d->server->viewers.end()) return G_SOURCE_REMOVE;
  Viewer& v = *it->second;
  v.deadline = 0;
  const gint64 now = g_get_monotonic_time(), offered = v.ctl->offered_us;
  const gint64 handshake_us = d->server->opt.handshake_s * G_USEC_PER_SEC;
  gint64 until = 0;  // the page (we offer): our offer still coming, or the browser's time not over
  if (v.ws && offered == 0 && now < v.built_us + kOfferBoundS * G_USEC_PER_SEC) {
    until = now + G_USEC_PER_SEC / 2;
    if (!v.ctl->offer_taken && v.ctl->offers_asked < kOfferAsks &&
        now >= v.built_us + (v.ctl->offers_asked + 1) * kOfferRetryS * G_USEC_PER_SEC) {
      ++v.ctl->offers_asked;
      say(d->server,
          "viewer %u: no offer %" G_GINT64_FORMAT
          " s after connecting (webrtcbin %s): asking again",
          v.ctl->viewer_id, (now - v.built_us) / G_USEC_PER_SEC,
          v.ctl->negotiation_needed ? "was asked for one" : "did not ask for negotiation");
      ask_offer(v.ctl);
    }
  } else if (v.ws && offered && now < offered + handshake_us)
    until = offered + handshake_us;
  if (until) {
    v.deadline = arm_deadline(d->server, d->serial, (until - now + 999) / 1000);
    return G_SOURCE_REMOVE;
  }
  if (!v.answered || !v.ctl->connected) {
    const std::string why =
        v.ws && offered == 0
            ? "webrtcbin made no offer within " + std::to_string(kOfferBoundS) + " s"
            : std::string(v.answered ? "no ICE connection" : "no SDP answer") + " within " +
                  std::to_string(d->server->opt.handshake_s) + " s (--handshake-timeout)";
    remove_viewer(d->server, d->serial, why.c_str());
  }
  return G_SOURCE_REMOVE;
}

// A viewer's branch, in the pipeline and playing: its requests into the
// request mux, its fragments from the demux; with `own_channel`, the control
// data channel made here (the WebSocket page, where the server offers),
// else the peer's (WHEP: the player offers and opens it).
std::unique_ptr<Viewer> build_viewer(Server* s, const std::string& address, bool own_channel) {
  auto v = std::make_unique<Viewer>();
  auto ctl = std::make_shared<Control>();
  ctl->server = s;
  ctl->serial = s->next_serial++;
  ctl->viewer_id = free_viewer_id(s);
  GError* err = nullptr;
  GstElement* bin = gst_parse_bin_from_description(
      viewer_description(s->opt, ctl->viewer_id).c_str(), FALSE, &err);
  if (!bin) {
    std::fprintf(stderr, "lf-web: cannot build a viewer: %s\n", err->message);
    g_error_free(err);
    return nullptr;
  }
  gchar* name = g_strdup_printf("viewer%u", ctl->viewer_id);
  gst_object_set_name(GST_OBJECT(bin), name);
  g_free(name);
  ctl->request = gst_bin_get_by_name(GST_BIN(bin), "req");
  ctl->compositor = gst_bin_get_by_name(GST_BIN(bin), "comp");
  ctl->webrtc = gst_bin_get_by_name(GST_BIN(bin), "webrtc");
  // No UPnP port mapping: libnice's default starts an HTTP server and SSDP
  // sockets per viewer (GUPnP) that a server on a LAN never needs, and some
  // of them outlived the viewer.
  GObject* ice = nullptr;
  g_object_get(ctl->webrtc, "ice-agent", &ice, nullptr);
  if (ice && g_object_class_find_property(G_OBJECT_GET_CLASS(ice), "agent")) {
    GObject* agent = nullptr;
    g_object_get(ice, "agent", &agent, nullptr);
    if (agent && g_object_class_find_property(G_OBJECT_GET_CLASS(agent), "upnp"))
      g_object_set(agent, "upnp", FALSE, nullptr);
    if (agent) g_object_unref(agent);
  }
  if (ice) g_object_unref(ice);
  GstPad* src = ghost(bin, "req", "src", "src");
  GstPad* sink_l = ghost(bin, "ql", "sink", "sink_l");
  GstPad* sink_r = ghost(bin, "qr", "sink", "sink_r");
  gst_bin_add(GST_BIN(s->pipeline), bin);
  v->bin = bin;
  v->mux_pad = gst_element_request_pad_simple(s->mux, "sink_%u");
  gst_pad_link(src, v->mux_pad);
  // The server offers (the page; WHEP's player offers): its handlers are
  // connected before READY, when webrtcbin's own thread starts and may emit
  // on-negotiation-needed for the data channel, once; connected after, a
  // viewer could miss it and never get an offer (a lifetime test once
  // waited 20 s for one; GStreamer's own webrtc examples connect first).
  if (own_channel) {
    g_signal_connect_data(ctl->webrtc, "on-negotiation-needed", G_CALLBACK(on_negotiation_needed),
                          new_ref(ctl), delete_ref_closure, GConnectFlags(0));
    g_signal_connect_data(ctl->webrtc, "on-ice-candidate", G_CALLBACK(on_ice_candidate),
                          new_ref(ctl), delete_ref_closure, GConnectFlags(0));
  }
  // The data channel: after READY, before PLAYING (webrtcbin).
  gst_element_set_state(bin, GST_STATE_READY);
  GstWebRTCDataChannel* ch = nullptr;
  if (own_channel) {
    GstStructure* opts = gst_structure_new("options", "ordered", G_TYPE_BOOLEAN, TRUE, nullptr);
    g_signal_emit_by_name(ctl->webrtc, "create-data-channel", "control", opts, &ch);
    gst_structure_free(opts);
  } else {
    g_signal_connect_data(ctl->webrtc, "on-data-channel", G_CALLBACK(on_remote_channel),
                          new_ref(ctl), delete_ref_closure, GConnectFlags(0));
  }
  if (!ch && own_channel) {
    std::fprintf(stderr,
                 "lf-web: webrtcbin made no data channel (is gstreamer1.0-nice installed?)\n");
  } else if (ch) {
    connect_channel(ch, ctl);
    v->channel = ch;  // our reference: remove_viewer disconnects these handlers
  }
  g_signal_connect_data(ctl->webrtc, "notify::ice-connection-state", G_CALLBACK(on_ice_state),
                        new_ref(ctl), delete_ref_closure, GConnectFlags(0));
  gst_element_sync_state_with_parent(bin);
  // Fragments in last: the branch is playing, so nothing reaches a flushing
  // pad (which would stop the shared cameras' stream).
  for (int eye = 0; eye < 2; ++eye) {
    gchar* pn = g_strdup_printf("src_%u", ctl->viewer_id + eye);
    v->demux_pads[eye] = gst_element_request_pad_simple(s->demux, pn);
    g_free(pn);
    if (v->demux_pads[eye]) gst_pad_link(v->demux_pads[eye], eye ? sink_r : sink_l);
  }
  v->ctl = ctl;
  v->address = address;
  v->built_us = g_get_monotonic_time();
  // The page's first look comes by kOfferRetryS, to ask again for a missing offer.
  const gint64 first_s =
      own_channel ? std::min<gint64>(s->opt.handshake_s, kOfferRetryS) : s->opt.handshake_s;
  v->deadline = arm_deadline(s, ctl->serial, 1000 * first_s);
  return v;
}

bool add_viewer(Server* s, SoupWebsocketConnection* ws, const std::string& address) {
  std::unique_ptr<Viewer> v = build_viewer(s, address, true);
  if (!v) return false;
  const std::shared_ptr<Control> ctl = v->ctl;
  v->ws = SOUP_WEBSOCKET_CONNECTION(g_object_ref(ws));
  soup_websocket_connection_set_max_incoming_payload_size(ws, kMaxSignalBytes);
  soup_websocket_connection_set_keepalive_interval(ws, 15);
  g_signal_connect(ws, "message", G_CALLBACK(on_ws_message),
                   reinterpret_cast<gpointer>(ctl->serial));
  g_signal_connect(ws, "closed", G_CALLBACK(on_ws_closed), reinterpret_cast<gpointer>(ctl->serial));
  const double dmin = s->opt.fx * s->opt.spacing / 24, dmax = s->opt.fx * s->opt.spacing / 0.1;
  soup_websocket_connection_send_text(
      ws,
      json{{"type", "hello"},
           {"viewer", ctl->viewer_id},
           {"width", s->opt.width},
           {"height", s->opt.height},
           {"fps", s->opt.fps},
           {"cameras", s->opt.cameras},
           {"focal_depth_range", {dmin, dmax}},
           {"aperture_range",
            {lf::aperture_diameter(1, s->opt.spacing), lf::aperture_diameter(4, s->opt.spacing)}}}
          .dump()
          .c_str());
  say(s, "viewer %u connected from %s (%zu viewer%s)", ctl->viewer_id, address.c_str(),
      s->viewers.size() + 1, s->viewers.empty() ? "" : "s");
  s->viewers[ctl->serial] = std::move(v);
  return true;
}

void remove_viewer(Server* s, guint64 serial, const char* why) {
  auto it = s->viewers.find(serial);
  if (it == s->viewers.end()) return;
  std::unique_ptr<Viewer> v = std::move(it->second);
  s->viewers.erase(it);
  // The demux pads first (the shared stream then drops this viewer's
  // fragments), then the branch stops, then its request pad goes.
  for (GstPad* p : v->demux_pads)
    if (p) gst_element_release_request_pad(s->demux, p), gst_object_unref(p);
  if (v->deadline) g_source_remove(v->deadline);
  gst_element_set_state(v->bin, GST_STATE_NULL);
  {
    std::lock_guard<std::mutex> l(v->ctl->channel_lock);
    if (v->ctl->channel) g_object_unref(v->ctl->channel), v->ctl->channel = nullptr;
  }
  // The signal handlers of webrtcbin and of the data channel each hold a
  // reference to the Control, which holds webrtcbin: disconnecting them
  // breaks that cycle, so the branch (its threads, sockets, encoder) is
  // freed with the bin. Without this every viewer stayed behind.
  g_signal_handlers_disconnect_matched(v->ctl->webrtc, G_SIGNAL_MATCH_FUNC, 0, 0, nullptr,
                                       reinterpret_cast<gpointer>(on_negotiation_needed), nullptr);
  g_signal_handlers_disconnect_matched(v->ctl->webrtc, G_SIGNAL_MATCH_FUNC, 0, 0, nullptr,
                                       reinterpret_cast<gpointer>(on_ice_candidate), nullptr);
  g_signal_handlers_disconnect_matched(v->ctl->webrtc, G_SIGNAL_MATCH_FUNC, 0, 0, nullptr,
                                       reinterpret_cast<gpointer>(on_ice_state), nullptr);
  g_signal_handlers_disconnect_matched(v->ctl->webrtc, G_SIGNAL_MATCH_FUNC, 0, 0, nullptr,
                                       reinterpret_cast<gpointer>(on_remote_channel), nullptr);
  g_signal_handlers_disconnect_matched(v->ctl->webrtc, G_SIGNAL_MATCH_FUNC, 0, 0, nullptr,
                                       reinterpret_cast<gpointer>(on_gathering), nullptr);
  if (v->whep_timer) g_source_remove(v->whep_timer);
  if (v->whep_post) {  // removed before its answer: the player hears why
    soup_server_message_set_status(v->whep_post, SOUP_STATUS_SERVICE_UNAVAILABLE, nullptr);
    soup_server_message_set_response(v->whep_post, "text/plain; charset=utf-8", SOUP_MEMORY_COPY,
                                     why, strlen(why));
    soup_server_message_unpause(v->whep_post);
    g_object_unref(v->whep_post);
  }
  if (v->channel) release_channel(v->channel);
  if (v->ws) g_signal_handlers_disconnect_by_data(v->ws, reinterpret_cast<gpointer>(serial));
  gst_element_release_request_pad(s->mux, v->mux_pad);
  gst_object_unref(v->mux_pad);
  gst_bin_remove(GST_BIN(s->pipeline), v->bin);
  // The branch's messages still queued on the bus (each holds its element:
  // a state change of webrtcbin holds webrtcbin, its ICE thread and its
  // sockets) go now, so the branch is freed here, not when the bus gets to them.
  drain_bus(s);
  if (v->ws && soup_websocket_connection_get_state(v->ws) == SOUP_WEBSOCKET_STATE_OPEN)
    soup_websocket_connection_close(v->ws, SOUP_WEBSOCKET_CLOSE_NORMAL, why);
  if (v->ws) g_object_unref(v->ws);
  // The branch's memory back to the system: glibc keeps freed memory in its
  // per-thread arenas, and a viewer's threads leave arenas of their own
  // (without this the RSS rose by about half after a few hundred viewers).
  malloc_trim(0);
  say(s, "viewer %u left: %s (%zu viewer%s; %llu control messages, %llu refused)",
      v->ctl->viewer_id, why, s->viewers.size(), s->viewers.size() == 1 ? "" : "s",
      static_cast<unsigned long long>(v->ctl->messages.load()),
      static_cast<unsigned long long>(v->ctl->refused.load()));
}

void on_ws_closed(SoupWebsocketConnection* ws, gpointer data) {
  Server* s = static_cast<Server*>(g_object_get_data(G_OBJECT(ws), "lf-server"));
  remove_viewer(s, reinterpret_cast<guint64>(data), "the browser closed the connection");
}

// Twice a second: each viewer's state as the server sees it, on its data
// channel (the page's status line; the browser test reads it too), with
// its compositor's last lf-rate message (docs/steering.md) in JSON form.
gboolean send_stats(gpointer data) {
  Server* s = static_cast<Server*>(data);
  for (auto& [serial, v] : s->viewers) {
    Control& c = *v->ctl;
    guint64 frames = 0;
    guint cams = 0;
    gdouble es = 0, et = 0, ew = 0, depth = 0, aperture = 0;
    gint sampling = 0;
    gboolean surface = FALSE;
    g_object_get(c.compositor, "frames", &frames, "last-cameras", &cams, nullptr);
    g_object_get(c.request, "eye-s", &es, "eye-t", &et, "eye-w", &ew, "focal-depth", &depth,
                 "aperture", &aperture, "sampling", &sampling, "focal-surface", &surface, nullptr);
    c.send({{"type", "stats"},
            {"viewer", c.viewer_id},
            {"frames", frames},
            {"cameras_answered", c.stereo ? cams / 2 : cams},
            {"cameras", s->opt.cameras},
            {"viewers", s->viewers.size()},
            {"eye", {es, et, ew}},
            {"focal_depth", depth},
            {"aperture", aperture},
            {"sampling",
             sampling == static_cast<gint>(lf::Sampling::kBicubic) ? "bicubic" : "bilinear"},
            {"focal_surface", surface != FALSE},
            {"stereo", c.stereo.load()},
            {"refused", c.refused.load()},
            {"rate", c.rate}});
  }
  return G_SOURCE_CONTINUE;
}

// One message of the pipeline's bus.
void handle_message(Server* s, GstMessage* m) {
  const GstStructure* st = gst_message_get_structure(m);
  if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ELEMENT && st && gst_structure_has_name(st, "lf-rate")) {
    // A viewer's achieved rate, for its stats (the codec's JSON form).
    for (auto& [serial, v] : s->viewers)
      if (gst_object_has_as_ancestor(m->src, GST_OBJECT(v->bin))) v->ctl->rate = structure_json(st);
    return;
  }
  if (GST_MESSAGE_TYPE(m) != GST_MESSAGE_ERROR && GST_MESSAGE_TYPE(m) != GST_MESSAGE_WARNING)
    return;
  GError* err = nullptr;
  gchar* dbg = nullptr;
  if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR)
    gst_message_parse_error(m, &err, &dbg);
  else
    gst_message_parse_warning(m, &err, &dbg);
  const bool error = GST_MESSAGE_TYPE(m) == GST_MESSAGE_ERROR;
  std::fprintf(stderr, "lf-web: %s from %s: %s%s%s\n", error ? "error" : "warning",
               GST_OBJECT_NAME(m->src), err->message, dbg ? "\n  " : "", dbg ? dbg : "");
  g_clear_error(&err);
  g_free(dbg);
  if (!error) return;
  // From a viewer's branch already removed (posted before it left): nothing
  // more to end.
  if (!gst_object_has_as_ancestor(m->src, GST_OBJECT(s->pipeline))) return;
  // An error inside one viewer's branch ends that viewer; anywhere else, the server.
  for (auto& [serial, v] : s->viewers)
    if (gst_object_has_as_ancestor(m->src, GST_OBJECT(v->bin))) {
      g_main_context_invoke(nullptr, deliver, new Post{s, serial, ""});
      return;
    }
  s->exit_code = 1;
  g_main_loop_quit(s->loop);
}

// The bus watch: a message, then the others already queued. A GstBus watch
// hands over one message a main-loop iteration, and each viewer's branch
// posts about a hundred (state changes of its elements) while the loop also
// serves the connections: a peer opening and closing connections at once
// made the queue grow without bound, and every viewer with a message in it
// stayed alive with its threads and sockets (1,000 such cycles in 3 s held
// 1,039 threads and 996 fds: tests/web/lifetime-test.mjs, the "at once" phase).
gboolean on_bus(GstBus*, GstMessage* m, gpointer data) {
  Server* s = static_cast<Server*>(data);
  handle_message(s, m);
  drain_bus(s);
  return TRUE;
}

void drain_bus(Server* s) {
  GstBus* bus = gst_element_get_bus(s->pipeline);
  GstMessage* m = nullptr;
  // Bounded: other threads may post as fast as this pops.
  for (int k = 0; k < kBusDrain && (m = gst_bus_pop(bus)); ++k) {
    handle_message(s, m);
    gst_message_unref(m);
  }
  gst_object_unref(bus);
}

gboolean on_sigint(gpointer data) {
  Server* s = static_cast<Server*>(data);
  say(s, "interrupted: stopping");
  g_main_loop_quit(s->loop);
  return G_SOURCE_REMOVE;
}

const char* kSummary =
    "Serves the live light field to web browsers over WebRTC: open http://HOST:PORT/ and\n"
    "each browser steers its own virtual camera (drag: move the eye over the camera\n"
    "plane; wheel or slider: focal plane; right click or Ctrl+click: focus there;\n"
    "stereo; reset). The cameras are shared by every browser; each browser has its own\n"
    "view requests, compositor, VP8 encoder and webrtcbin. One TCP port serves the page\n"
    "(/), the signalling WebSocket (/ws) and a WHEP endpoint (POST /whep/default or\n"
    "/whep/orbit, RFC 9725; a WHEP player page at /whep.html); video and control go\n"
    "over WebRTC (UDP).\n"
    "\n"
    "Example (the bundled Chess light field, an 8x8 block of its 17x17 cameras):\n"
    "  lf-web --rig ../shared/data/stanford-chess\n"
    "then open http://THIS-HOST:8080/ in Chromium or Firefox.";

}  // namespace lfweb

using namespace lfweb;

int main(int argc, char** argv) {
  // One malloc arena, not glibc's eight a core: every viewer's threads
  // otherwise leave arenas of their own whose freed memory stays mapped
  // (RSS 164 -> 205 MiB over 2000 viewers; with two arenas it still came
  // back 66 -> 77 MiB in one run of five; with one, within 2 % in every run:
  // tests/web/lifetime-test.mjs). Small allocations still go through each
  // thread's own cache (tcache) without the arena's lock. Set before any
  // thread starts.
  mallopt(M_ARENA_MAX, 1);
  gchar *rig = nullptr, *block = nullptr, *size = nullptr, *address = nullptr, *stun = nullptr,
        *source = nullptr, *token = nullptr;
  gchar** allow_origin = nullptr;
  gdouble input_scale = 1;
  gint port = 8080, fps = 15, bitrate = 1500, max_viewers = 8, latency = 200, per_address = 4,
       handshake = 10;
  gboolean quiet = FALSE;
  const GOptionEntry entries[] = {
      {"rig", 0, 0, G_OPTION_ARG_FILENAME, &rig, "Rig file (.json) or dataset folder (required)",
       "PATH"},
      {"block", 0, 0, G_OPTION_ARG_STRING, &block,
       "Cameras: this block of the grid (default: the 8x8 block at 0,0 of a larger grid)",
       "R0,C0,ROWS,COLS"},
      {"input-scale", 0, 0, G_OPTION_ARG_DOUBLE, &input_scale,
       "Camera images resized by S (default 1)", "S"},
      {"size", 0, 0, G_OPTION_ARG_STRING, &size, "Size of every browser's view (default 640x480)",
       "WxH"},
      {"framerate", 0, 0, G_OPTION_ARG_INT, &fps,
       "View requests and video frames per second (default 15)", "FPS"},
      {"port", 0, 0, G_OPTION_ARG_INT, &port,
       "TCP port of the page and the signalling (default 8080; 0: any free port, printed)", "PORT"},
      {"address", 0, 0, G_OPTION_ARG_STRING, &address,
       "Listen on this address only (default: every address, so other machines can open the page)",
       "ADDR"},
      {"bitrate", 0, 0, G_OPTION_ARG_INT, &bitrate,
       "VP8 target bitrate per browser, kbit/s (default 1500)", "KBPS"},
      {"max-viewers", 0, 0, G_OPTION_ARG_INT, &max_viewers,
       "Browsers served at once; more are refused with a message (default 8)", "N"},
      {"max-per-address", 0, 0, G_OPTION_ARG_INT, &per_address,
       "Browsers served at once from one IP address (default 4)", "N"},
      {"handshake-timeout", 0, 0, G_OPTION_ARG_INT, &handshake,
       "Seconds a browser has, from the server's offer, to answer it and connect before its "
       "slot is freed (default 10)",
       "S"},
      {"token", 0, 0, G_OPTION_ARG_STRING, &token,
       "Require this secret: the page is opened as http://HOST:PORT/?token=SECRET (default: none; "
       "anyone who reaches the port can watch and steer)",
       "SECRET"},
      {"allow-origin", 0, 0, G_OPTION_ARG_STRING_ARRAY, &allow_origin,
       "Also accept WebSocket upgrades from pages of this origin (repeatable; '*': any). By "
       "default only the page's own origin",
       "http://HOST:PORT"},
      {"latency", 0, 0, G_OPTION_ARG_INT, &latency,
       "Compositor deadline, ms: a view leaves when every camera answered, or then (default 200)",
       "MS"},
      {"stun", 0, 0, G_OPTION_ARG_STRING, &stun,
       "STUN server for browsers beyond a NAT (default none: a LAN needs none)",
       "stun://HOST:PORT"},
      {"source", 0, 0, G_OPTION_ARG_STRING, &source,
       "The cameras, as a bin description with one view-request sink and one fragment source "
       "(default: lfcamerahost rig=RIG is-live=true framerate=FPS; e.g. RTP to camera hosts)",
       "DESCRIPTION"},
      {"quiet", 'q', 0, G_OPTION_ARG_NONE, &quiet, "Print only warnings and errors", nullptr},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  GOptionContext* octx = g_option_context_new("- light field viewers in web browsers");
  g_option_context_set_summary(octx, kSummary);
  g_option_context_add_main_entries(octx, entries, nullptr);
  g_option_context_add_group(octx, gst_init_get_option_group());
  GError* err = nullptr;
  if (!g_option_context_parse(octx, &argc, &argv, &err)) {
    std::fprintf(stderr, "lf-web: error: %s (see --help)\n", err->message);
    return 2;
  }
  g_option_context_free(octx);
  Server s;
  Options& o = s.opt;
  o.quiet = quiet;
  o.fps = fps, o.port = port, o.bitrate_kbps = bitrate, o.max_viewers = max_viewers,
  o.latency_ms = latency;
  if (address) o.address = address;
  if (stun) o.stun = stun;
  o.max_per_address = per_address, o.handshake_s = handshake;
  const bool empty_token = token && *token == '\0';
  if (token) o.token = token;
  for (gchar** a = allow_origin; a && *a; ++a) o.allow_origin.emplace_back(*a);
  g_free(token);
  g_strfreev(allow_origin);
  gchar* tmpdir = nullptr;
  try {
    if (!rig) throw std::invalid_argument("--rig is required (a rig file or dataset folder)");
    if (size) cli::parse_size(size, o.width, o.height);
    if (fps < 1 || fps > 120) throw std::invalid_argument("--framerate outside 1..120");
    if (port < 0 || port > 65535) throw std::invalid_argument("--port outside 0..65535");
    if (bitrate < 50 || bitrate > 100000)
      throw std::invalid_argument("--bitrate outside 50..100000 kbit/s");
    if (max_viewers < 1 || max_viewers > 64)
      throw std::invalid_argument("--max-viewers outside 1..64");
    if (per_address < 1 || per_address > 64)
      throw std::invalid_argument("--max-per-address outside 1..64");
    if (handshake < 1 || handshake > 600)
      throw std::invalid_argument("--handshake-timeout outside 1..600 s");
    if (empty_token) throw std::invalid_argument("--token is empty");
    if (latency < 1 || latency > 10000)
      throw std::invalid_argument("--latency outside 1..10000 ms");
    lf::Rig r =
        cli::select_cameras(lf::load_rig_or_dataset(rig), block ? block : "", 0, input_scale, true);
    if (r.cameras.empty()) throw std::invalid_argument("the rig has no cameras");
    o.cameras = r.cameras.size();
    o.spacing = r.typical_spacing();
    o.fx = r.cameras[0].intrinsics.fx;
    tmpdir = g_dir_make_tmp("lf-web-XXXXXX", nullptr);
    if (!tmpdir) throw std::runtime_error("cannot make a temporary folder");
    o.rig_path = std::string(tmpdir) + "/rig.json";
    lf::save_rig(r, o.rig_path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lf-web: error: %s (see --help)\n", e.what());
    return 2;
  }
  o.source = source ? source
                    : "lfcamerahost rig=\"" + o.rig_path +
                          "\" is-live=true framerate=" + std::to_string(o.fps) + "/1";
  g_free(rig), g_free(block), g_free(size), g_free(address), g_free(stun), g_free(source);
  g_resources_register(lf_web_get_resource());

  // The shared part: requests of every viewer -> cameras -> fragments by viewer.
  s.pipeline = gst_pipeline_new("lf-web");
  s.mux = gst_element_factory_make("lfrequestmux", "requests");
  s.demux = gst_element_factory_make("lffragmentdemux", "fragments");
  GstElement* cams = gst_parse_bin_from_description(o.source.c_str(), TRUE, &err);
  if (!s.mux || !s.demux || !cams) {
    std::fprintf(stderr, "lf-web: error: %s\n",
                 err ? err->message : "lfrequestmux or lffragmentdemux missing (GST_PLUGIN_PATH?)");
    return 1;
  }
  GstElementFactory* webrtc_factory = gst_element_factory_find("webrtcbin");
  GstElementFactory* nice_factory = gst_element_factory_find("nicesrc");
  const bool have_webrtc = webrtc_factory && nice_factory;
  if (webrtc_factory) gst_object_unref(webrtc_factory);
  if (nice_factory) gst_object_unref(nice_factory);
  if (!have_webrtc) {
    std::fprintf(stderr,
                 "lf-web: error: webrtcbin and libnice's elements are needed (Debian: "
                 "gstreamer1.0-plugins-bad, gstreamer1.0-nice)\n");
    return 1;
  }
  gst_bin_add_many(GST_BIN(s.pipeline), s.mux, cams, s.demux, nullptr);
  if (!gst_element_link_many(s.mux, cams, s.demux, nullptr)) {
    std::fprintf(stderr,
                 "lf-web: error: --source needs one view-request sink and one fragment source\n");
    return 1;
  }
  GstBus* bus = gst_element_get_bus(s.pipeline);
  gst_bus_add_watch(bus, on_bus, &s);
  gst_object_unref(bus);
  if (gst_element_set_state(s.pipeline, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE) {
    std::fprintf(stderr, "lf-web: error: the camera pipeline does not start\n");
    return 1;
  }

  s.soup = soup_server_new("server-header", "lf-web ", nullptr);
  soup_server_add_handler(s.soup, nullptr, on_http, &s, nullptr);
  soup_server_add_handler(s.soup, "/ws", on_ws_gate, &s, nullptr);
  soup_server_add_handler(s.soup, "/whep", on_whep, &s, nullptr);
  soup_server_add_websocket_handler(s.soup, "/ws", nullptr, nullptr, on_websocket, &s, nullptr);
  GInetAddress* ia = g_inet_address_new_from_string(o.address.c_str());
  if (!ia) {
    std::fprintf(stderr, "lf-web: error: --address '%s' is not an IP address\n", o.address.c_str());
    return 2;
  }
  GSocketAddress* sa = g_inet_socket_address_new(ia, static_cast<guint16>(o.port));
  g_object_unref(ia);
  int bound_port = 0;  // --port 0: the port the system chose
  if (!lfweb::listen_on(&s, sa, &bound_port, &err)) {
    std::fprintf(stderr, "lf-web: error: cannot listen on %s port %d: %s\n", o.address.c_str(),
                 o.port, err->message);
    return 1;
  }
  g_object_unref(sa);
  o.port = bound_port;
  say(&s, "%zu cameras, views %dx%d at %d fps; open http://%s:%d/ (Ctrl+C stops)", o.cameras,
      o.width, o.height, o.fps, o.address == "0.0.0.0" ? g_get_host_name() : o.address.c_str(),
      o.port);

  s.loop = g_main_loop_new(nullptr, FALSE);
  g_unix_signal_add(SIGINT, on_sigint, &s);
  g_unix_signal_add(SIGTERM, on_sigint, &s);
  g_timeout_add(500, send_stats, &s);
  g_main_loop_run(s.loop);

  while (!s.viewers.empty()) remove_viewer(&s, s.viewers.begin()->first, "the server stopped");
  lfweb::stop_listening(&s);
  soup_server_disconnect(s.soup);
  g_object_unref(s.soup);
  gst_element_set_state(s.pipeline, GST_STATE_NULL);
  gst_object_unref(s.pipeline);
  g_main_loop_unref(s.loop);
  if (tmpdir) {
    g_remove(o.rig_path.c_str());
    g_rmdir(tmpdir);
    g_free(tmpdir);
  }
  return s.exit_code;
}
