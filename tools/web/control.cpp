// lf-web: the view control protocol on a viewer's data channel (docs/web.md).
#include "web/lf-web.h"

namespace lfweb {

// A finite number from a JSON field, or an error.
bool number_field(const json& j, const char* key, double* out, std::string* err) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_number()) {
    *err = std::string("'") + key + "' must be a number";
    return false;
  }
  *out = it->get<double>();
  if (!std::isfinite(*out)) {
    *err = std::string("'") + key + "' is not finite";
    return false;
  }
  return true;
}

// Refuses any field not in `known` (a typo must not pass silently).
bool only_fields(const json& j, std::initializer_list<const char*> known, std::string* err) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (std::none_of(known.begin(), known.end(), [&](const char* k) { return it.key() == k; })) {
      *err = "unknown field '" + it.key().substr(0, 64) + "'";
      return false;
    }
  }
  return true;
}

// A position in the picture the browser shows (video pixels).
bool point_fields(const Control& c, const json& j, double* x, double* y, std::string* err) {
  if (!number_field(j, "x", x, err) || !number_field(j, "y", y, err)) return false;
  const int w = c.stereo ? 2 * c.server->opt.width : c.server->opt.width, h = c.server->opt.height;
  if (*x < 0 || *y < 0 || *x >= w || *y >= h) {
    *err = "point outside the " + std::to_string(w) + "x" + std::to_string(h) + " picture";
    return false;
  }
  return true;
}

// Upstream events go straight to this viewer's lfviewrequest, which handles
// them as it handles those from a video sink (docs/steering.md: navigation, lf-view).
void to_request(Control& c, GstEvent* ev) {
  GstPad* pad = gst_element_get_static_pad(c.request, "src");
  gst_pad_send_event(pad, ev);
  gst_object_unref(pad);
}

// The view fields a browser may set (of lfviewrequest's properties that may
// change while playing; docs/web.md).
constexpr const char* kViewFields[] = {"eye-s",       "eye-t", "eye-w",
                                       "focal-depth", "vfov",  "aperture"};

// An lf-view message, the JSON form of the lf-view event (gst/lfevents.h):
// {"type": "lf-view", FIELD: VALUE, ...}, each field one of kViewFields and
// a number. The structure is checked by the codec's own reader against
// this viewer's lfviewrequest (its property types and ranges, finite
// numbers), exactly as the element checks it, and sent whole. Returns an
// error text, empty when sent.
std::string send_view_change(Control& c, const json& j) {
  std::vector<std::pair<std::string, double>> fields;
  std::string err;
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (it.key() == "type") continue;
    double v = 0;
    if (std::none_of(std::begin(kViewFields), std::end(kViewFields),
                     [&](const char* k) { return it.key() == k; }))
      return "unknown field '" + it.key().substr(0, 64) + "'";
    if (!number_field(j, it.key().c_str(), &v, &err)) return err;
    fields.emplace_back(it.key(), v);
  }
  if (fields.empty()) return "'lf-view' without a field";
  GstStructure* s = lfgst::view_change_structure(fields);  // the codec's writer and reader
  std::vector<std::pair<GParamSpec*, GValue>> values;
  if (!lfgst::read_view_change(s, G_OBJECT(c.request), lfgst::kMaxCoordinate, &values, &err)) {
    gst_structure_free(s);
    return err;
  }
  for (auto& kv : values) g_value_unset(&kv.second);
  to_request(c, gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, s));
  return "";
}

json structure_json(const GstStructure* s) {
  json j = {{"type", gst_structure_get_name(s)}};
  for (gint i = 0; i < gst_structure_n_fields(s); ++i) {
    const gchar* name = gst_structure_nth_field_name(s, i);
    const GValue* v = gst_structure_get_value(s, name);
    GValue whole = G_VALUE_INIT;  // the integer types, as int64
    if (G_VALUE_HOLDS_DOUBLE(v)) {
      if (std::isfinite(g_value_get_double(v))) j[name] = g_value_get_double(v);
    } else if (G_VALUE_HOLDS_BOOLEAN(v)) {
      j[name] = g_value_get_boolean(v) != FALSE;
    } else if (G_VALUE_HOLDS_STRING(v)) {
      j[name] = g_value_get_string(v) ? g_value_get_string(v) : "";
    } else if (g_value_type_transformable(G_VALUE_TYPE(v), G_TYPE_INT64)) {
      g_value_init(&whole, G_TYPE_INT64);
      if (g_value_transform(v, &whole)) j[name] = g_value_get_int64(&whole);
      g_value_unset(&whole);
    }
  }
  return j;
}

// One control message. Returns an error text, empty when applied.
std::string apply_control(Control& c, const json& j) {
  std::string err;
  if (!j.is_object() || !j.contains("type") || !j["type"].is_string())
    return "not a JSON object with a 'type'";
  const std::string type = j["type"].get<std::string>();
  double x = 0, y = 0;
  if (type == "pointer") {
    if (!only_fields(j, {"type", "action", "button", "x", "y", "ctrl"}, &err)) return err;
    if (!point_fields(c, j, &x, &y, &err)) return err;
    const std::string action = j.value("action", "");
    if (action == "move") {
      to_request(c, gst_navigation_event_new_mouse_move(x, y, GST_NAVIGATION_MODIFIER_NONE));
      return "";
    }
    if (!j.contains("button") || !j["button"].is_number_integer()) return "'button' must be 1 or 3";
    const int button = j["button"].get<int>();
    if (button != 1 && button != 3) return "'button' must be 1 or 3";
    if (action == "press")
      to_request(c, gst_navigation_event_new_mouse_button_press(button, x, y,
                                                                GST_NAVIGATION_MODIFIER_NONE));
    else if (action == "release")
      to_request(c, gst_navigation_event_new_mouse_button_release(button, x, y,
                                                                  GST_NAVIGATION_MODIFIER_NONE));
    else
      return "'action' must be press, release or move";
    return "";
  }
  if (type == "wheel") {  // one notch nearer (+1) or farther (-1): 0.25 px of parallax
    double dy = 0;
    if (!only_fields(j, {"type", "dy", "x", "y"}, &err) || !number_field(j, "dy", &dy, &err))
      return err;
    if (std::fabs(dy) > 10) return "'dy' outside -10..10 notches";
    to_request(c, gst_navigation_event_new_mouse_scroll(0, 0, 0, dy, GST_NAVIGATION_MODIFIER_NONE));
    return "";
  }
  if (type == "focus") {  // click to focus: the scene under this pixel
    if (!only_fields(j, {"type", "x", "y"}, &err) || !point_fields(c, j, &x, &y, &err)) return err;
    to_request(c,
               gst_navigation_event_new_mouse_button_press(3, x, y, GST_NAVIGATION_MODIFIER_NONE));
    to_request(
        c, gst_navigation_event_new_mouse_button_release(3, x, y, GST_NAVIGATION_MODIFIER_NONE));
    return "";
  }
  if (type == "key") {
    static const std::set<std::string> keys = {"Left",    "Right",     "Up", "Down",
                                               "Page_Up", "Page_Down", "r"};
    if (!only_fields(j, {"type", "key"}, &err)) return err;
    if (!j.contains("key") || !j["key"].is_string() || !keys.count(j["key"].get<std::string>()))
      return "'key' must be one of Left, Right, Up, Down, Page_Up, Page_Down, r";
    to_request(c, gst_navigation_event_new_key_press(j["key"].get<std::string>().c_str(),
                                                     GST_NAVIGATION_MODIFIER_NONE));
    return "";
  }
  // View properties, applied at once and whole ("set" is the page's older
  // name for it).
  if (type == "lf-view" || type == "set") return send_view_change(c, j);
  if (type == "stereo") {  // left | right side by side, one camera spacing apart
    if (!only_fields(j, {"type", "on"}, &err)) return err;
    if (!j.contains("on") || !j["on"].is_boolean()) return "'on' must be true or false";
    const bool on = j["on"].get<bool>();
    if (on == c.stereo) return "";
    c.stereo = on;
    // On: the right eye's requests first, then the compositor waits for them;
    // off: the other way round.
    if (on) g_object_set(c.request, "stereo-baseline", c.server->opt.spacing, nullptr);
    g_object_set(c.compositor, "stereo", on ? TRUE : FALSE, nullptr);
    if (!on) g_object_set(c.request, "stereo-baseline", 0.0, nullptr);
    return "";
  }
  if (type == "sampling") {  // how the cameras resample: bilinear | bicubic
    if (!only_fields(j, {"type", "filter"}, &err)) return err;
    if (!j.contains("filter") || !j["filter"].is_string() ||
        (j["filter"] != "bilinear" && j["filter"] != "bicubic"))
      return "'filter' must be bilinear or bicubic";
    gst_util_set_object_arg(G_OBJECT(c.request), "sampling",
                            j["filter"].get<std::string>().c_str());
    return "";
  }
  if (type == "surface") {  // a focal surface (true) or the focal plane of the slider (false)
    if (!only_fields(j, {"type", "on"}, &err)) return err;
    if (!j.contains("on") || !j["on"].is_boolean()) return "'on' must be true or false";
    g_object_set(c.request, "focal-surface", j["on"].get<bool>() ? TRUE : FALSE, nullptr);
    return "";
  }
  if (type == "ping") {  // round trip of the control path, measured by the page
    if (!only_fields(j, {"type", "t"}, &err) || !number_field(j, "t", &x, &err)) return err;
    c.send({{"type", "pong"}, {"t", x}});
    return "";
  }
  return "unknown message type '" + type.substr(0, 64) + "'";
}

void on_control_message(GstWebRTCDataChannel*, gchar* text, gpointer data) {
  Control& c = *ref_of(data);
  c.messages++;
  if (!c.limit.take())
    return refuse(c, "too many control messages (limit " + std::to_string(int(kControlRate)) +
                         "/s): dropped");
  const size_t n = text ? strnlen(text, kMaxControlBytes + 1) : 0;
  if (n > kMaxControlBytes)
    return refuse(c,
                  "control message over " + std::to_string(kMaxControlBytes) + " bytes: dropped");
  json j = json::parse(text, text + n, nullptr, false);
  if (j.is_discarded())
    return refuse(c, "control message is not valid JSON (NaN and Infinity are not JSON)");
  const std::string err = apply_control(c, j);
  if (!err.empty()) refuse(c, "control message refused: " + err);
}

void on_control_bytes(GstWebRTCDataChannel*, GBytes*, gpointer data) {
  refuse(*ref_of(data), "binary control message: dropped (the protocol is JSON text)");
}

void on_channel_open(GstWebRTCDataChannel* ch, gpointer data) {
  Control& c = *ref_of(data);
  std::lock_guard<std::mutex> l(c.channel_lock);
  if (!c.channel) c.channel = GST_WEBRTC_DATA_CHANNEL(g_object_ref(ch));
}

void on_channel_close(GstWebRTCDataChannel*, gpointer data) {
  Control& c = *ref_of(data);
  std::lock_guard<std::mutex> l(c.channel_lock);
  if (c.channel) g_object_unref(c.channel), c.channel = nullptr;
}

// The control protocol on a data channel (the server's own, or the one a
// WHEP player opened): each handler holds a reference to the viewer's
// Control, dropped with the handler.
void connect_channel(GstWebRTCDataChannel* ch, const ControlRef& ctl) {
  g_signal_connect_data(ch, "on-open", G_CALLBACK(on_channel_open), new_ref(ctl),
                        delete_ref_closure, GConnectFlags(0));
  g_signal_connect_data(ch, "on-close", G_CALLBACK(on_channel_close), new_ref(ctl),
                        delete_ref_closure, GConnectFlags(0));
  g_signal_connect_data(ch, "on-message-string", G_CALLBACK(on_control_message), new_ref(ctl),
                        delete_ref_closure, GConnectFlags(0));
  g_signal_connect_data(ch, "on-message-data", G_CALLBACK(on_control_bytes), new_ref(ctl),
                        delete_ref_closure, GConnectFlags(0));
}

// Undoes connect_channel (so no handler keeps the Control alive) and drops
// our reference to the channel.
void release_channel(GstWebRTCDataChannel* ch) {
  for (gpointer f :
       {reinterpret_cast<gpointer>(on_channel_open), reinterpret_cast<gpointer>(on_channel_close),
        reinterpret_cast<gpointer>(on_control_message),
        reinterpret_cast<gpointer>(on_control_bytes)})
    g_signal_handlers_disconnect_matched(ch, G_SIGNAL_MATCH_FUNC, 0, 0, nullptr, f, nullptr);
  g_object_unref(ch);
}

}  // namespace lfweb
