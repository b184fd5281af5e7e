// lf-web: the WebRTC signalling with a browser: the server's SDP offer and
// ICE candidates out (webrtcbin's signals, on GStreamer's threads, posted
// to the main thread), the browser's answer and candidates in (JSON on the
// WebSocket, every field checked, at most kMaxIceCandidates).
#include "web/lf-web.h"

namespace lfweb {

// The offer's promise holds only a weak reference: webrtcbin may drop a
// promise it never answers (a viewer removed while its offer was being
// made), and a strong one would then keep the Control, and through it the
// webrtcbin with its ICE agent's sockets, for ever.
void on_offer(GstPromise* promise, gpointer data) {
  auto ctl = static_cast<std::weak_ptr<Control>*>(data)->lock();
  if (!ctl) {
    gst_promise_unref(promise);
    return;
  }
  GstWebRTCSessionDescription* offer = nullptr;
  if (gst_promise_wait(promise) == GST_PROMISE_RESULT_REPLIED)
    gst_structure_get(gst_promise_get_reply(promise), "offer", GST_TYPE_WEBRTC_SESSION_DESCRIPTION,
                      &offer, nullptr);
  gst_promise_unref(promise);
  if (offer && ctl->offer_taken.exchange(true)) {  // another offer went out first
    gst_webrtc_session_description_free(offer);
    return;
  }
  if (!offer) {  // the viewer goes, unless an offer it asked for again went out
    if (ctl->offer_taken) return;
    std::fprintf(stderr, "lf-web: viewer %u: webrtcbin made no offer\n", ctl->viewer_id);
    post(*ctl, "");
    return;
  }
  g_signal_emit_by_name(ctl->webrtc, "set-local-description", offer, nullptr);
  ctl->offered_us = g_get_monotonic_time();
  gchar* sdp = gst_sdp_message_as_text(offer->sdp);
  post(*ctl, json{{"type", "offer"}, {"sdp", sdp}}.dump());
  g_free(sdp);
  gst_webrtc_session_description_free(offer);
}

void ask_offer(const ControlRef& ctl) {
  GstPromise* p = gst_promise_new_with_change_func(
      on_offer, new std::weak_ptr<Control>(ctl),
      [](gpointer d) { delete static_cast<std::weak_ptr<Control>*>(d); });
  g_signal_emit_by_name(ctl->webrtc, "create-offer", nullptr, p);
}

void on_negotiation_needed(GstElement*, gpointer data) {
  ref_of(data)->negotiation_needed = true;
  ask_offer(ref_of(data));
}

void on_ice_candidate(GstElement*, guint mline, gchar* candidate, gpointer data) {
  post(*ref_of(data),
       json{{"type", "ice"}, {"candidate", candidate}, {"sdpMLineIndex", mline}}.dump());
}

void on_ice_state(GstElement* webrtc, GParamSpec*, gpointer data) {
  GstWebRTCICEConnectionState state;
  g_object_get(webrtc, "ice-connection-state", &state, nullptr);
  if (state == GST_WEBRTC_ICE_CONNECTION_STATE_CONNECTED ||
      state == GST_WEBRTC_ICE_CONNECTION_STATE_COMPLETED)
    ref_of(data)->connected = true;
  if (state == GST_WEBRTC_ICE_CONNECTION_STATE_FAILED) {
    std::fprintf(stderr, "lf-web: viewer %u: ICE failed\n", ref_of(data)->viewer_id);
    post(*ref_of(data), "");
  }
}

// Signal handler data (on_negotiation_needed, on_ice_candidate,
// on_ice_state): a heap copy of the viewer's shared_ptr, deleted with the
// handler (so the Control outlives every callback in flight).

// Signalling from the browser: the SDP answer, then ICE candidates.
void on_ws_message(SoupWebsocketConnection* ws, gint type, GBytes* message, gpointer data) {
  Server* s = static_cast<Server*>(g_object_get_data(G_OBJECT(ws), "lf-server"));
  auto it = s->viewers.find(reinterpret_cast<guint64>(data));
  if (it == s->viewers.end()) return;
  Viewer& v = *it->second;
  Control& c = *v.ctl;
  if (type != SOUP_WEBSOCKET_DATA_TEXT) return refuse(c, "binary signalling message: dropped");
  if (!c.limit.take()) return refuse(c, "too many signalling messages: dropped");
  gsize n = 0;
  const char* text = static_cast<const char*>(g_bytes_get_data(message, &n));
  json j = json::parse(text, text + n, nullptr, false);
  std::string err;
  if (j.is_discarded() || !j.is_object() || !j.contains("type") || !j["type"].is_string())
    return refuse(c, "signalling message is not a JSON object with a 'type'");
  const std::string t = j["type"].get<std::string>();
  if (t == "answer") {
    if (!only_fields(j, {"type", "sdp"}, &err)) return refuse(c, err);
    if (v.answered) return refuse(c, "a second SDP answer: dropped");
    if (!j.contains("sdp") || !j["sdp"].is_string()) return refuse(c, "'sdp' must be a string");
    GstSDPMessage* sdp = nullptr;
    if (gst_sdp_message_new_from_text(j["sdp"].get<std::string>().c_str(), &sdp) != GST_SDP_OK ||
        !sdp)
      return refuse(c, "the SDP answer does not parse");
    if (gst_sdp_message_medias_len(sdp) == 0) {
      gst_sdp_message_free(sdp);
      return refuse(c, "the SDP answer has no media");
    }
    GstWebRTCSessionDescription* d =
        gst_webrtc_session_description_new(GST_WEBRTC_SDP_TYPE_ANSWER, sdp);
    g_signal_emit_by_name(c.webrtc, "set-remote-description", d, nullptr);
    gst_webrtc_session_description_free(d);
    v.answered = true;
  } else if (t == "ice") {
    if (!only_fields(j, {"type", "candidate", "sdpMLineIndex"}, &err)) return refuse(c, err);
    if (!j.contains("candidate") || !j["candidate"].is_string() || !j.contains("sdpMLineIndex") ||
        !j["sdpMLineIndex"].is_number_unsigned())
      return refuse(c,
                    "an ICE candidate needs 'candidate' (string) and 'sdpMLineIndex' (0, 1, ...)");
    const std::string cand = j["candidate"].get<std::string>();
    const unsigned mline = j["sdpMLineIndex"].get<unsigned>();
    if (cand.empty()) return;  // end of candidates
    if (cand.size() > 1024 || mline > 8)
      return refuse(c, "ICE candidate too long or m-line out of range");
    if (++v.candidates > kMaxIceCandidates) return refuse(c, "too many ICE candidates: dropped");
    g_signal_emit_by_name(c.webrtc, "add-ice-candidate", mline, cand.c_str());
  } else {
    refuse(c, "unknown signalling message '" + t.substr(0, 64) + "'");
  }
}

}  // namespace lfweb
