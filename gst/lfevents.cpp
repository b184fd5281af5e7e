#include "lfevents.h"

#include <gst/video/navigation.h>

#include <cmath>

namespace lfgst {

namespace {
constexpr gsize kSurfacePlaneBytes = 4 * sizeof(double);
bool fail(std::string* why, const std::string& text) {
  if (why) *why = text;
  return false;
}
}  // namespace

bool version_ok(const GstStructure* s, std::string* why) {
  guint v = 1;
  if (gst_structure_has_field(s, "version") && !gst_structure_get_uint(s, "version", &v))
    return fail(why, "version must be a uint");
  if (v < 1 || v > kEventVersion)
    return fail(why, std::string(gst_structure_get_name(s)) + " version " + std::to_string(v) +
                         ": this build reads up to version " + std::to_string(kEventVersion));
  return true;
}

GstStructure* focus_structure(const FocusAnswer& a) {
  return gst_structure_new("lf-focus", "version", G_TYPE_UINT, kEventVersion, "viewer-id",
                           G_TYPE_UINT, a.viewer, "probe-id", G_TYPE_UINT, a.probe, "inverse-depth",
                           G_TYPE_DOUBLE, a.inverse_depth, "capture-time", G_TYPE_INT64,
                           a.capture_ns, nullptr);
}

bool read_focus(const GstStructure* s, FocusAnswer* a, std::string* why) {
  if (!gst_structure_has_name(s, "lf-focus")) return fail(why, "not an lf-focus structure");
  if (!version_ok(s, why)) return false;
  if (!gst_structure_get_uint(s, "probe-id", &a->probe) ||
      !gst_structure_get_double(s, "inverse-depth", &a->inverse_depth) ||
      !std::isfinite(a->inverse_depth) || a->inverse_depth < 0)
    return fail(why, "needs probe-id (uint) and inverse-depth (double >= 0)");
  if (!gst_structure_get_uint(s, "viewer-id", &a->viewer)) a->viewer = 0;
  if (!gst_structure_get_int64(s, "capture-time", &a->capture_ns)) a->capture_ns = -1;
  return true;
}

GstStructure* surface_structure(const SurfaceAnswer& a) {
  const lf::FocalSurface& fs = a.surface;
  std::vector<double> planes;
  for (const lf::FocalPlane& pl : fs.planes)
    planes.insert(planes.end(), {pl.n[0], pl.n[1], pl.n[2], pl.d});
  GBytes* pb = g_bytes_new(planes.data(), planes.size() * sizeof(double));
  GBytes* ob = g_bytes_new(fs.plane_of.data(), fs.plane_of.size());
  GstStructure* s = gst_structure_new(
      "lf-surface", "version", G_TYPE_UINT, kEventVersion, "viewer-id", G_TYPE_UINT, a.viewer,
      "probe-id", G_TYPE_UINT, a.probe, "capture-time", G_TYPE_INT64, a.capture_ns, "tile",
      G_TYPE_INT, fs.tile, "cols", G_TYPE_INT, fs.cols, "rows", G_TYPE_INT, fs.rows, "planes",
      G_TYPE_BYTES, pb, "plane-of", G_TYPE_BYTES, ob, "planes-used", G_TYPE_INT, a.planes_used,
      nullptr);
  g_bytes_unref(pb);
  g_bytes_unref(ob);
  if (fs.two_planes()) {
    GBytes* sb = g_bytes_new(fs.second_of.data(), fs.second_of.size());
    gst_structure_set(s, "second-of", G_TYPE_BYTES, sb, nullptr);
    g_bytes_unref(sb);
  }
  return s;
}

namespace {
// The grid, planes and plane indices of an lf-surface structure.
bool read_surface_fields(const GstStructure* s, SurfaceAnswer* a) {
  const GValue* pv = gst_structure_get_value(s, "planes");
  const GValue* ov = gst_structure_get_value(s, "plane-of");
  GBytes* planes =
      pv && G_VALUE_HOLDS(pv, G_TYPE_BYTES) ? static_cast<GBytes*>(g_value_get_boxed(pv)) : nullptr;
  GBytes* plane_of =
      ov && G_VALUE_HOLDS(ov, G_TYPE_BYTES) ? static_cast<GBytes*>(g_value_get_boxed(ov)) : nullptr;
  gint tile = 0, cols = 0, rows = 0;
  if (!gst_structure_get_uint(s, "probe-id", &a->probe) ||
      !gst_structure_get_int(s, "tile", &tile) || !gst_structure_get_int(s, "cols", &cols) ||
      !gst_structure_get_int(s, "rows", &rows) || !planes || !plane_of ||
      tile < lf::FocalSurface::kMinTile || tile > lf::FocalSurface::kMaxTile || cols < 1 ||
      rows < 1 || cols > 16384 || rows > 16384)
    return false;
  gsize np = 0, no = 0;
  const auto* d = static_cast<const double*>(g_bytes_get_data(planes, &np));
  const auto* o = static_cast<const uint8_t*>(g_bytes_get_data(plane_of, &no));
  if (np % kSurfacePlaneBytes != 0 || np < kSurfacePlaneBytes ||
      np > lf::FocalSurface::kMaxPlanes * kSurfacePlaneBytes ||
      no != static_cast<gsize>(cols) * static_cast<gsize>(rows))
    return false;
  a->surface.tile = tile, a->surface.cols = cols, a->surface.rows = rows;
  a->surface.planes.clear();
  for (gsize i = 0; i < np / kSurfacePlaneBytes; ++i) {
    lf::FocalPlane pl;
    pl.n = cv::Vec3d(d[4 * i], d[4 * i + 1], d[4 * i + 2]);
    pl.d = d[4 * i + 3];
    a->surface.planes.push_back(pl);
  }
  a->surface.plane_of.assign(o, o + no);
  a->surface.second_of.clear();
  if (const GValue* sv = gst_structure_get_value(s, "second-of")) {
    if (!G_VALUE_HOLDS(sv, G_TYPE_BYTES)) return false;
    gsize ns = 0;
    const auto* so = static_cast<const uint8_t*>(
        g_bytes_get_data(static_cast<GBytes*>(g_value_get_boxed(sv)), &ns));
    if (ns != no) return false;
    a->surface.second_of.assign(so, so + ns);
  }
  return true;
}
}  // namespace

bool read_surface(const GstStructure* s, SurfaceAnswer* a, std::string* why) {
  static const char* kWhat =
      "needs probe-id (uint), tile (4..1024), cols and rows (1..16384), planes (bytes: 1..64 "
      "planes of 4 doubles) and plane-of (bytes: cols x rows)";
  if (!gst_structure_has_name(s, "lf-surface")) return fail(why, "not an lf-surface structure");
  if (!version_ok(s, why)) return false;
  if (!read_surface_fields(s, a)) return fail(why, kWhat);
  if (!gst_structure_get_uint(s, "viewer-id", &a->viewer)) a->viewer = 0;
  if (!gst_structure_get_int64(s, "capture-time", &a->capture_ns)) a->capture_ns = -1;
  if (!gst_structure_get_int(s, "planes-used", &a->planes_used)) a->planes_used = 0;
  return true;
}

bool read_view_change(const GstStructure* s, GObject* target, double max_coord,
                      std::vector<std::pair<GParamSpec*, GValue>>* values, std::string* why) {
  if (!gst_structure_has_name(s, "lf-view")) return fail(why, "not an lf-view structure");
  if (!version_ok(s, why)) return false;
  std::string bad;
  for (gint i = 0; i < gst_structure_n_fields(s) && bad.empty(); ++i) {
    const gchar* name = gst_structure_nth_field_name(s, i);
    if (g_str_equal(name, "viewer-id") || g_str_equal(name, "version")) continue;
    GParamSpec* ps = g_object_class_find_property(G_OBJECT_GET_CLASS(target), name);
    if (!ps || !(ps->flags & GST_PARAM_MUTABLE_PLAYING)) {
      bad = std::string("unknown field '") + name + "'";
      break;
    }
    const GValue* in = gst_structure_get_value(s, name);
    GValue v = G_VALUE_INIT;
    g_value_init(&v, ps->value_type);
    bool ok;
    if (ps->value_type == GST_TYPE_ARRAY) {
      ok = GST_VALUE_HOLDS_ARRAY(in) &&
           (gst_value_array_get_size(in) == 0 || gst_value_array_get_size(in) == 3);
      for (guint k = 0; ok && k < gst_value_array_get_size(in); ++k) {
        GValue d = G_VALUE_INIT;
        g_value_init(&d, G_TYPE_DOUBLE);
        ok = g_value_transform(gst_value_array_get_value(in, k), &d) &&
             std::isfinite(g_value_get_double(&d)) &&
             std::fabs(g_value_get_double(&d)) <= max_coord;
        if (ok)
          gst_value_array_append_and_take_value(&v, &d);
        else
          g_value_unset(&d);
      }
    } else {
      ok = g_value_type_transformable(G_VALUE_TYPE(in), ps->value_type) &&
           g_value_transform(in, &v) &&
           !(G_VALUE_HOLDS_DOUBLE(&v) && !std::isfinite(g_value_get_double(&v))) &&
           !g_param_value_validate(ps, &v);  // true when it had to clamp
    }
    if (!ok) {
      bad = std::string("field '") + name + "' is not a valid " + g_type_name(ps->value_type) +
            " for the property (see gst-inspect-1.0 lfviewrequest)";
      g_value_unset(&v);
      break;
    }
    values->emplace_back(ps, v);
  }
  if (bad.empty()) return true;
  for (auto& kv : *values) g_value_unset(&kv.second);
  values->clear();
  return fail(why, bad);
}

GstStructure* view_change_structure(const std::vector<std::pair<std::string, double>>& fields,
                                    gint64 viewer) {
  GstStructure* s = gst_structure_new("lf-view", "version", G_TYPE_UINT, kEventVersion, nullptr);
  if (viewer >= 0)
    gst_structure_set(s, "viewer-id", G_TYPE_UINT, static_cast<guint>(viewer), nullptr);
  for (const auto& [name, value] : fields)
    gst_structure_set(s, name.c_str(), G_TYPE_DOUBLE, value, nullptr);
  return s;
}

GstEvent* view_event(const GstStructure* fields, GObject* target, double max_coord,
                     std::string* why) {
  GstStructure* in = gst_structure_copy(fields);
  gst_structure_set_name(in, "lf-view");
  std::vector<std::pair<GParamSpec*, GValue>> values;
  const bool ok = read_view_change(in, target, max_coord, &values, why);
  const std::optional<guint> viewer = addressed_viewer(in);
  const bool addressed_ok = viewer || !gst_structure_has_field(in, "viewer-id");
  gst_structure_free(in);
  if (ok && !addressed_ok) {
    for (auto& kv : values) g_value_unset(&kv.second);
    return fail(why, "field 'viewer-id' is not a viewer id (uint)"), nullptr;
  }
  if (!ok) return nullptr;
  GstStructure* out = view_change_structure({}, viewer ? gint64{*viewer} : -1);
  for (auto& [ps, v] : values) gst_structure_take_value(out, ps->name, &v);
  return gst_event_new_custom(GST_EVENT_CUSTOM_UPSTREAM, out);
}

std::optional<guint> addressed_viewer(const GstStructure* s) {
  guint id = 0;
  gint sid = 0;
  if (gst_structure_get_uint(s, "viewer-id", &id)) return id;
  if (gst_structure_get_int(s, "viewer-id", &sid) && sid >= 0) return static_cast<guint>(sid);
  return std::nullopt;
}

GstEvent* address_to_viewer(GstEvent* event, gint viewer) {
  if (viewer < 0 || gst_structure_has_field(gst_event_get_structure(event), "viewer-id"))
    return event;
  event = gst_event_make_writable(event);
  gst_structure_set(gst_event_writable_structure(event), "viewer-id", G_TYPE_UINT,
                    static_cast<guint>(viewer), nullptr);
  return event;
}

bool read_gesture(GstEvent* event, lf::Gesture* g) {
  using Kind = lf::Gesture::Kind;
  double dx = 0;
  const gchar* key = nullptr;
  switch (gst_navigation_event_get_type(event)) {
    case GST_NAVIGATION_EVENT_MOUSE_BUTTON_PRESS: {
      GstNavigationModifierType mods = GST_NAVIGATION_MODIFIER_NONE;
      gst_navigation_event_parse_modifier_state(event, &mods);
      g->kind = Kind::kPress, g->control = mods & GST_NAVIGATION_MODIFIER_CONTROL_MASK;
      return gst_navigation_event_parse_mouse_button_event(event, &g->button, &g->x, &g->y);
    }
    case GST_NAVIGATION_EVENT_MOUSE_BUTTON_RELEASE:
      g->kind = Kind::kRelease;
      return gst_navigation_event_parse_mouse_button_event(event, &g->button, &g->x, &g->y);
    case GST_NAVIGATION_EVENT_MOUSE_MOVE:
      g->kind = Kind::kMove;
      return gst_navigation_event_parse_mouse_move_event(event, &g->x, &g->y);
    case GST_NAVIGATION_EVENT_MOUSE_SCROLL:
      g->kind = Kind::kScroll;
      return gst_navigation_event_parse_mouse_scroll_event(event, &g->x, &g->y, &dx, &g->dy);
    case GST_NAVIGATION_EVENT_KEY_PRESS:
      g->kind = Kind::kKey;
      if (!gst_navigation_event_parse_key_event(event, &key) || !key) return false;
      g->key = key;
      return true;
    default:
      return false;
  }
}

GstStructure* answer_structure(lf::ProbeOutcome&& o) {
  if (o.kind == lf::ProbeOutcome::Kind::kFocus)
    return focus_structure({o.viewer, o.probe, o.inverse_depth, o.capture_time_ns});
  return surface_structure(
      {o.viewer, o.probe, o.capture_time_ns, std::move(o.surface), o.planes_used});
}

GstStructure* rate_structure(gint64 viewer, double requested_fps, const lf::OutputRate::Report& r,
                             guint64 over_budget, guint64 stale) {
  return gst_structure_new("lf-rate", "version", G_TYPE_UINT, kEventVersion, "viewer-id",
                           G_TYPE_INT64, viewer, "requested-fps", G_TYPE_DOUBLE, requested_fps,
                           "fps", G_TYPE_DOUBLE, r.fps(), "complete-fps", G_TYPE_DOUBLE,
                           r.complete_fps(), "interval", G_TYPE_DOUBLE, r.seconds, "over-budget",
                           G_TYPE_UINT64, over_budget, "stale", G_TYPE_UINT64, stale, nullptr);
}

void post_rate(GstElement* el, gint64 viewer, double requested_fps, const lf::OutputRate::Report& r,
               guint64 over_budget, guint64 stale) {
  gst_element_post_message(
      el, gst_message_new_element(GST_OBJECT(el),
                                  rate_structure(viewer, requested_fps, r, over_budget, stale)));
}

}  // namespace lfgst
