// lf-web: WHEP, the WebRTC-HTTP Egress Protocol (RFC 9725).
#include "web/lf-web.h"

namespace lfweb {

// ---- WHEP (RFC 9725: WebRTC-HTTP Egress Protocol) ---------------------------
//
// POST /whep/<view> with an SDP offer (application/sdp) makes a viewer
// whose webrtcbin answers; the answer, with every ICE candidate gathered
// (no trickle: PATCH is 405), comes back as 201 Created with Location
// /whep/resource/<id>; DELETE there ends the viewer. The player's data
// channel, if its offer has one, speaks the page's control protocol.

// The viewer of a serial and its main-thread work, from a GStreamer thread.
struct WhepEvent {
  Server* server;
  guint64 serial;
  GstWebRTCDataChannel* channel;  // (ref) on-data-channel's, or null: gathering complete
};

void answer_whep(Server* s, guint64 serial);

gboolean on_whep_event(gpointer data) {
  std::unique_ptr<WhepEvent> e(static_cast<WhepEvent*>(data));
  auto it = e->server->viewers.find(e->serial);
  if (!e->channel) {
    if (it != e->server->viewers.end()) answer_whep(e->server, e->serial);
    return G_SOURCE_REMOVE;
  }
  if (it != e->server->viewers.end() && !it->second->channel) {
    it->second->channel = e->channel;  // remove_viewer disconnects its handlers
    return G_SOURCE_REMOVE;
  }
  // The viewer is gone (or has a channel already): no handler may keep its
  // Control alive.
  release_channel(e->channel);
  return G_SOURCE_REMOVE;
}

// The player's data channel (announced open): the control protocol on it.
void on_remote_channel(GstElement*, GstWebRTCDataChannel* ch, gpointer data) {
  const ControlRef& ctl = ref_of(data);
  connect_channel(ch, ctl);
  on_channel_open(ch, data);  // a channel the peer opened is open already
  g_main_context_invoke(
      nullptr, on_whep_event,
      new WhepEvent{ctl->server, ctl->serial, GST_WEBRTC_DATA_CHANNEL(g_object_ref(ch))});
}

void on_gathering(GstElement* webrtc, GParamSpec*, gpointer data) {
  GstWebRTCICEGatheringState state;
  g_object_get(webrtc, "ice-gathering-state", &state, nullptr);
  if (state == GST_WEBRTC_ICE_GATHERING_STATE_COMPLETE)
    g_main_context_invoke(nullptr, on_whep_event,
                          new WhepEvent{ref_of(data)->server, ref_of(data)->serial, nullptr});
}

// Once: the local description (the answer with its candidates) as 201.
void answer_whep(Server* s, guint64 serial) {
  auto it = s->viewers.find(serial);
  if (it == s->viewers.end() || !it->second->whep_post) return;
  Viewer& v = *it->second;
  if (v.whep_timer) g_source_remove(v.whep_timer), v.whep_timer = 0;
  GstWebRTCSessionDescription* local = nullptr;
  g_object_get(v.ctl->webrtc, "local-description", &local, nullptr);
  if (!local) {
    remove_viewer(s, serial, "webrtcbin made no answer to the offer");
    return;
  }
  gchar* sdp = gst_sdp_message_as_text(local->sdp);
  gst_webrtc_session_description_free(local);
  SoupServerMessage* msg = v.whep_post;
  v.whep_post = nullptr;
  const std::string where = "/whep/resource/" + std::to_string(serial);
  SoupMessageHeaders* h = soup_server_message_get_response_headers(msg);
  soup_message_headers_replace(h, "Location", where.c_str());
  soup_message_headers_replace(h, "Cache-Control", "no-store");
  soup_server_message_set_status(msg, SOUP_STATUS_CREATED, nullptr);
  soup_server_message_set_response(msg, "application/sdp", SOUP_MEMORY_COPY, sdp, strlen(sdp));
  soup_server_message_unpause(msg);
  g_object_unref(msg);
  g_free(sdp);
  say(s, "WHEP viewer %u answered (%s)", v.ctl->viewer_id, where.c_str());
}

gboolean on_whep_timer(gpointer data) {
  const auto* d = static_cast<const Deadline*>(data);
  auto it = d->server->viewers.find(d->serial);
  if (it != d->server->viewers.end()) it->second->whep_timer = 0;
  answer_whep(d->server, d->serial);  // with the candidates gathered so far
  return G_SOURCE_REMOVE;
}

void on_answer_made(GstPromise* promise, gpointer data) {
  auto ctl = static_cast<std::weak_ptr<Control>*>(data)->lock();
  GstWebRTCSessionDescription* answer = nullptr;
  if (gst_promise_wait(promise) == GST_PROMISE_RESULT_REPLIED)
    gst_structure_get(gst_promise_get_reply(promise), "answer", GST_TYPE_WEBRTC_SESSION_DESCRIPTION,
                      &answer, nullptr);
  gst_promise_unref(promise);
  if (!ctl) {
    if (answer) gst_webrtc_session_description_free(answer);
    return;
  }
  if (!answer) {
    std::fprintf(stderr,
                 "lf-web: WHEP viewer %u: webrtcbin made no answer (an offer without a "
                 "video m-line it can send VP8 on?)\n",
                 ctl->viewer_id);
    post(*ctl, "");
    return;
  }
  g_signal_emit_by_name(ctl->webrtc, "set-local-description", answer, nullptr);
  gst_webrtc_session_description_free(answer);
}

void reply(SoupServerMessage* msg, guint status, const std::string& why) {
  soup_server_message_set_status(msg, status, status == 429 ? "Too Many Requests" : nullptr);
  soup_message_headers_replace(soup_server_message_get_response_headers(msg), "Connection",
                               "close");
  if (!why.empty())
    soup_server_message_set_response(msg, "text/plain; charset=utf-8", SOUP_MEMORY_COPY,
                                     why.c_str(), why.size());
}

std::string refusal(const Server* s, SoupServerMessage* msg, const char* token, guint* status);
bool same_secret(const std::string& a, const std::string& b);

// The bearer token of a WHEP request (Authorization: Bearer T), or ?token=.
const char* whep_token(SoupServerMessage* msg, GHashTable* query) {
  const char* auth =
      soup_message_headers_get_one(soup_server_message_get_request_headers(msg), "Authorization");
  if (auth && g_ascii_strncasecmp(auth, "Bearer ", 7) == 0) return auth + 7;
  return query ? static_cast<const char*>(g_hash_table_lookup(query, "token")) : nullptr;
}

void on_http(SoupServer*, SoupServerMessage* msg, const char* path, GHashTable*, gpointer);

void on_whep(SoupServer* server, SoupServerMessage* msg, const char* path, GHashTable* query,
             gpointer data) {
  Server* s = static_cast<Server*>(data);
  const std::string method = soup_server_message_get_method(msg);
  const std::string p = path;
  // libsoup hands this handler every path that starts with "/whep", the
  // page /whep.html included.
  if (p != "/whep" && p.compare(0, 6, "/whep/") != 0)
    return on_http(server, msg, path, query, data);
  const std::string resource = "/whep/resource/";
  if (method == "OPTIONS") {
    SoupMessageHeaders* h = soup_server_message_get_response_headers(msg);
    soup_message_headers_replace(h, "Accept-Post", "application/sdp");
    soup_message_headers_replace(h, "Allow", "OPTIONS, POST, DELETE");
    soup_server_message_set_status(msg, SOUP_STATUS_NO_CONTENT, nullptr);
    return;
  }
  if (p.compare(0, resource.size(), resource) == 0) {  // a session
    if (method == "PATCH")
      return reply(msg, SOUP_STATUS_METHOD_NOT_ALLOWED,
                   "no trickle ICE: the answer carries every candidate");
    if (method != "DELETE") return reply(msg, SOUP_STATUS_METHOD_NOT_ALLOWED, "DELETE ends it");
    const char* t = whep_token(msg, query);
    if (!s->opt.token.empty() && (!t || !same_secret(t, s->opt.token)))
      return reply(msg, SOUP_STATUS_UNAUTHORIZED, "no or a wrong token (--token)");
    const std::string id = p.substr(resource.size());
    guint64 serial = 0;
    if (id.empty() || id.size() > 19 || id.find_first_not_of("0123456789") != std::string::npos ||
        !s->viewers.count(serial = std::stoull(id)) || s->viewers[serial]->ws)
      return reply(msg, SOUP_STATUS_NOT_FOUND, "no such WHEP session");
    remove_viewer(s, serial, "the WHEP player ended the session (DELETE)");
    soup_server_message_set_status(msg, SOUP_STATUS_OK, nullptr);
    return;
  }
  // POST /whep/<view>: the views a player may ask for.
  static const std::map<std::string, const char*> views = {
      {"/whep", ""}, {"/whep/default", ""}, {"/whep/orbit", "orbit"}};
  auto view = views.find(p);
  if (view == views.end())
    return reply(msg, SOUP_STATUS_NOT_FOUND, "views: /whep/default, /whep/orbit");
  if (method != "POST") return reply(msg, SOUP_STATUS_METHOD_NOT_ALLOWED, "POST an SDP offer");
  SoupMessageHeaders* req = soup_server_message_get_request_headers(msg);
  const char* type = soup_message_headers_get_content_type(req, nullptr);
  if (!type || g_ascii_strcasecmp(type, "application/sdp") != 0)
    return reply(msg, SOUP_STATUS_UNSUPPORTED_MEDIA_TYPE, "the offer must be application/sdp");
  SoupMessageBody* body = soup_server_message_get_request_body(msg);
  if (!body || body->length <= 0 || static_cast<gsize>(body->length) > kMaxSignalBytes)
    return reply(msg, SOUP_STATUS_REQUEST_ENTITY_TOO_LARGE,
                 "an SDP offer of 1.." + std::to_string(kMaxSignalBytes) + " bytes");
  guint status = 0;
  const std::string why = refusal(s, msg, whep_token(msg, query), &status);
  if (!why.empty()) {
    std::fprintf(stderr, "lf-web: refused a WHEP player: %s\n", why.c_str());
    return reply(msg, status, why);
  }
  const std::string text(body->data, body->length);
  GstSDPMessage* sdp = nullptr;
  if (gst_sdp_message_new_from_text(text.c_str(), &sdp) != GST_SDP_OK || !sdp ||
      gst_sdp_message_medias_len(sdp) == 0) {
    if (sdp) gst_sdp_message_free(sdp);
    return reply(msg, SOUP_STATUS_BAD_REQUEST, "the offer is not an SDP with media");
  }
  const char* address = soup_server_message_get_remote_host(msg);
  std::unique_ptr<Viewer> v = build_viewer(s, address ? address : "", false);
  if (!v) {
    gst_sdp_message_free(sdp);
    return reply(msg, SOUP_STATUS_INTERNAL_SERVER_ERROR, "cannot build a viewer");
  }
  const std::shared_ptr<Control> ctl = v->ctl;
  if (*view->second) g_object_set(ctl->request, "orbit", 0.5, nullptr);
  v->answered = true;  // the offer is here; the deadline waits for ICE
  v->whep_post = SOUP_SERVER_MESSAGE(g_object_ref(msg));
  soup_server_message_pause(msg);
  g_signal_connect_data(ctl->webrtc, "notify::ice-gathering-state", G_CALLBACK(on_gathering),
                        new_ref(ctl), delete_ref_closure, GConnectFlags(0));
  v->whep_timer =
      g_timeout_add_seconds_full(G_PRIORITY_DEFAULT, 5, on_whep_timer, new Deadline{s, ctl->serial},
                                 [](gpointer d) { delete static_cast<Deadline*>(d); });
  say(s, "WHEP viewer %u from %s (%zu viewer%s)", ctl->viewer_id, address ? address : "?",
      s->viewers.size() + 1, s->viewers.empty() ? "" : "s");
  s->viewers[ctl->serial] = std::move(v);
  GstWebRTCSessionDescription* offer =
      gst_webrtc_session_description_new(GST_WEBRTC_SDP_TYPE_OFFER, sdp);
  g_signal_emit_by_name(ctl->webrtc, "set-remote-description", offer, nullptr);
  gst_webrtc_session_description_free(offer);
  GstPromise* made = gst_promise_new_with_change_func(
      on_answer_made, new std::weak_ptr<Control>(ctl),
      [](gpointer d) { delete static_cast<std::weak_ptr<Control>*>(d); });
  g_signal_emit_by_name(ctl->webrtc, "create-answer", nullptr, made);
}

}  // namespace lfweb
