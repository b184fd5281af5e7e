// lf-web: the HTTP side: who may connect (token, Origin, per-address cap),
// the signalling WebSocket's upgrade and the page.
#include <netinet/in.h>
#include <netinet/tcp.h>

#include "lf-web-resources.h"  // the page (glib-compile-resources)
#include "web/lf-web.h"

namespace lfweb {

int viewers_from(const Server* s, const std::string& address) {
  return static_cast<int>(std::count_if(s->viewers.begin(), s->viewers.end(), [&](const auto& v) {
    return v.second->address == address;
  }));
}

// Equal strings, in a time that does not depend on where they differ.
bool same_secret(const std::string& a, const std::string& b) {
  if (a.size() != b.size()) return false;
  unsigned char d = 0;
  for (size_t i = 0; i < a.size(); ++i) d |= static_cast<unsigned char>(a[i] ^ b[i]);
  return d == 0;
}

// Why an upgrade to /ws is refused, or empty: the Origin (a page of another
// site must not steer a viewer: cross-site WebSocket hijacking), the token,
// the viewer slots and the slots of one address.
std::string refusal(const Server* s, SoupServerMessage* msg, const char* token, guint* status) {
  SoupMessageHeaders* h = soup_server_message_get_request_headers(msg);
  const char* origin = soup_message_headers_get_one(h, "Origin");
  const char* host = soup_message_headers_get_one(h, "Host");
  const auto& allow = s->opt.allow_origin;
  *status = SOUP_STATUS_FORBIDDEN;
  // A browser always sends Origin; a program without one speaks for itself.
  if (origin && !(host && std::string(origin) == std::string("http://") + host) &&
      std::find(allow.begin(), allow.end(), "*") == allow.end() &&
      std::find(allow.begin(), allow.end(), origin) == allow.end())
    return std::string("Origin '") + std::string(origin).substr(0, 128) +
           "' is not this page's (--allow-origin widens it)";
  if (!s->opt.token.empty()) {
    *status = SOUP_STATUS_UNAUTHORIZED;
    if (!token || !same_secret(token, s->opt.token)) return "no or a wrong token (--token)";
  }
  *status = SOUP_STATUS_SERVICE_UNAVAILABLE;
  if (static_cast<int>(s->viewers.size()) >= s->opt.max_viewers)
    return "the server has its " + std::to_string(s->opt.max_viewers) + " viewers (--max-viewers)";
  const char* address = soup_server_message_get_remote_host(msg);
  *status = 429;  // Too Many Requests (RFC 6585; libsoup 3.2 has no name for it)
  if (viewers_from(s, address ? address : "") >= s->opt.max_per_address)
    return std::string(address ? address : "this address") + " has its " +
           std::to_string(s->opt.max_per_address) + " viewers (--max-per-address)";
  return "";
}

// Before the upgrade to a WebSocket: a refused browser gets an HTTP status
// (403, 401, 503 or 429) and no viewer is built.
void on_ws_gate(SoupServer*, SoupServerMessage* msg, const char*, GHashTable* query,
                gpointer data) {
  const Server* s = static_cast<const Server*>(data);
  guint status = 0;
  const char* token =
      query ? static_cast<const char*>(g_hash_table_lookup(query, "token")) : nullptr;
  const std::string why = refusal(s, msg, token, &status);
  if (why.empty()) return;  // the upgrade goes on
  const char* address = soup_server_message_get_remote_host(msg);
  static gint64 last_warning = 0;  // at most one line a second: a flood is no log flood
  if (g_get_monotonic_time() - last_warning > G_USEC_PER_SEC) {
    last_warning = g_get_monotonic_time();
    std::fprintf(stderr, "lf-web: refused %s: %s\n", address ? address : "a browser", why.c_str());
  }
  soup_server_message_set_status(msg, status, status == 429 ? "Too Many Requests" : nullptr);
  // Closed after the answer: a refused peer keeps no connection (without
  // this libsoup waited on it for ever, one fd per refusal).
  soup_message_headers_replace(soup_server_message_get_response_headers(msg), "Connection",
                               "close");
  soup_server_message_set_response(msg, "text/plain; charset=utf-8", SOUP_MEMORY_COPY, why.c_str(),
                                   why.size());
}

void on_websocket(SoupServer*, SoupServerMessage* msg, const char*, SoupWebsocketConnection* ws,
                  gpointer data) {
  Server* s = static_cast<Server*>(data);
  g_object_set_data(G_OBJECT(ws), "lf-server", s);
  const char* address = soup_server_message_get_remote_host(msg);
  if (static_cast<int>(s->viewers.size()) >= s->opt.max_viewers) {
    const std::string m =
        "the server has its " + std::to_string(s->opt.max_viewers) + " viewers (--max-viewers)";
    std::fprintf(stderr, "lf-web: refused a browser: %s\n", m.c_str());
    soup_websocket_connection_send_text(ws, json{{"type", "error"}, {"message", m}}.dump().c_str());
    soup_websocket_connection_close(ws, SOUP_WEBSOCKET_CLOSE_GOING_AWAY, "full");
    return;
  }
  if (!add_viewer(s, ws, address ? address : ""))
    soup_websocket_connection_close(ws, SOUP_WEBSOCKET_CLOSE_SERVER_ERROR, "cannot build a viewer");
}

// The page and its script, from the GResource.
void on_http(SoupServer*, SoupServerMessage* msg, const char* path, GHashTable*, gpointer) {
  if (strcmp(soup_server_message_get_method(msg), "GET") != 0 &&
      strcmp(soup_server_message_get_method(msg), "HEAD") != 0) {
    soup_server_message_set_status(msg, SOUP_STATUS_METHOD_NOT_ALLOWED, nullptr);
    return;
  }
  static const std::map<std::string, std::pair<const char*, const char*>> files = {
      {"/", {"/lf-web/index.html", "text/html; charset=utf-8"}},
      {"/index.html", {"/lf-web/index.html", "text/html; charset=utf-8"}},
      {"/viewer.js", {"/lf-web/viewer.js", "text/javascript; charset=utf-8"}},
      {"/whep.html", {"/lf-web/whep.html", "text/html; charset=utf-8"}},
      {"/favicon.ico", {"/lf-web/favicon.svg", "image/svg+xml"}}};
  auto it = files.find(path);
  GBytes* body = it == files.end() ? nullptr
                                   : g_resources_lookup_data(it->second.first,
                                                             G_RESOURCE_LOOKUP_FLAGS_NONE, nullptr);
  if (!body) {
    soup_server_message_set_status(msg, SOUP_STATUS_NOT_FOUND, nullptr);
    return;
  }
  gsize n = 0;
  const void* d = g_bytes_get_data(body, &n);
  soup_server_message_set_status(msg, SOUP_STATUS_OK, nullptr);
  soup_message_headers_append(soup_server_message_get_response_headers(msg), "Cache-Control",
                              "no-store");
  soup_server_message_set_response(msg, it->second.second, SOUP_MEMORY_COPY,
                                   static_cast<const char*>(d), n);
  g_bytes_unref(body);
}

// A connection accepted by our GSocketService, handed to libsoup as a
// stream (libsoup's own listener in 3.2, Debian 12's, never unrefs the
// GSocket it accepts: 344 bytes a connection, fixed in libsoup 3.4).
static gboolean on_incoming(GSocketService*, GSocketConnection* c, GObject*, gpointer data) {
  auto* s = static_cast<Server*>(data);
  GSocketAddress* local = g_socket_connection_get_local_address(c, nullptr);
  GSocketAddress* remote = g_socket_connection_get_remote_address(c, nullptr);
  if (local && remote) {
    g_socket_set_option(g_socket_connection_get_socket(c), IPPROTO_TCP, TCP_NODELAY, TRUE, nullptr);
    soup_server_accept_iostream(s->soup, G_IO_STREAM(c), local, remote, nullptr);
  }  // else: the peer is gone already; the connection is closed when unreffed
  if (local) g_object_unref(local);
  if (remote) g_object_unref(remote);
  return TRUE;
}

bool listen_on(Server* s, GSocketAddress* address, int* port, GError** err) {
  s->service = g_socket_service_new();
  g_socket_listener_set_backlog(G_SOCKET_LISTENER(s->service), 128);
  GSocketAddress* bound = nullptr;
  if (!g_socket_listener_add_address(G_SOCKET_LISTENER(s->service), address, G_SOCKET_TYPE_STREAM,
                                     G_SOCKET_PROTOCOL_TCP, nullptr, &bound, err))
    return false;
  *port = g_inet_socket_address_get_port(G_INET_SOCKET_ADDRESS(bound));
  g_object_unref(bound);
  g_signal_connect(s->service, "incoming", G_CALLBACK(on_incoming), s);
  g_socket_service_start(s->service);
  return true;
}

void stop_listening(Server* s) {
  if (!s->service) return;
  g_socket_service_stop(s->service);
  g_socket_listener_close(G_SOCKET_LISTENER(s->service));
  g_object_unref(s->service);
  s->service = nullptr;
}

}  // namespace lfweb
