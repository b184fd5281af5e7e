// Element properties as a table over a plain settings struct, so each element
// declares a property once (its GParamSpec and the member it sets) and
// set_property / get_property are the same code for every element.
//
// Settings structs are written by set_property under the object lock and
// snapshotted, under the same lock, when an element starts (READY->PAUSED):
// streaming threads read the snapshot, never the live struct. Properties
// flagged GST_PARAM_MUTABLE_PLAYING are read live with read_setting().
#pragma once

#include <gst/base/gstbasesrc.h>
#include <gst/gst.h>

#include <atomic>
#include <functional>
#include <string>
#include <type_traits>
#include <vector>

namespace lfgst {

// A GStreamer fraction property (frame rates).
struct Fraction {
  gint n = 0, d = 1;
  bool operator==(const Fraction& o) const { return n == o.n && d == o.d; }
  double value() const { return d ? static_cast<double>(n) / d : 0; }
};

template <class S>
class Properties {
 public:
  // Installs `spec` on `oc` as the next property id, bound to member `m`.
  // Member types: std::string (string), gint, guint, guint64, gdouble,
  // bool (boolean), Fraction (GstFraction), std::vector<double>
  // (GstValueArray of doubles, gst_param_spec_array), enums (registered
  // GEnums) and std::atomic<guint64> (read-only counts that streaming
  // threads bump without the lock: counter_spec()).
  template <class T>
  void add(GObjectClass* oc, T S::*m, GParamSpec* spec) {
    Entry e;
    e.set = [m](S& s, const GValue* v) { assign(s.*m, v); };
    e.get = [m](const S& s, GValue* v) { fetch(s.*m, v); };
    entries_.push_back(std::move(e));
    g_object_class_install_property(oc, static_cast<guint>(entries_.size()), spec);
  }

  // A member of a base of S (settings that extend a lib struct).
  template <class T, class B,
            std::enable_if_t<!std::is_same<B, S>::value && std::is_base_of<B, S>::value, int> = 0>
  void add(GObjectClass* oc, T B::*m, GParamSpec* spec) {
    add(oc, static_cast<T S::*>(m), spec);
  }

  // set_property / get_property of an element whose settings are `s`.
  void set(GObject* obj, S& s, guint id, const GValue* v, GParamSpec* ps) const {
    if (const Entry* e = find(obj, id, ps)) {
      GST_OBJECT_LOCK(obj);
      e->set(s, v);
      GST_OBJECT_UNLOCK(obj);
    }
  }
  void get(GObject* obj, const S& s, guint id, GValue* v, GParamSpec* ps) const {
    if (const Entry* e = find(obj, id, ps)) {
      GST_OBJECT_LOCK(obj);
      e->get(s, v);
      GST_OBJECT_UNLOCK(obj);
    }
  }

 private:
  struct Entry {
    std::function<void(S&, const GValue*)> set;
    std::function<void(const S&, GValue*)> get;
  };
  static void assign(std::string& x, const GValue* v) {
    const gchar* s = g_value_get_string(v);
    x = s ? s : "";
  }
  static void assign(gint& x, const GValue* v) { x = g_value_get_int(v); }
  static void assign(guint& x, const GValue* v) { x = g_value_get_uint(v); }
  static void assign(guint64& x, const GValue* v) { x = g_value_get_uint64(v); }
  static void assign(std::atomic<guint64>& x, const GValue* v) { x = g_value_get_uint64(v); }
  static void assign(gdouble& x, const GValue* v) { x = g_value_get_double(v); }
  static void assign(bool& x, const GValue* v) { x = g_value_get_boolean(v); }
  static void assign(Fraction& x, const GValue* v) {
    x = {gst_value_get_fraction_numerator(v), gst_value_get_fraction_denominator(v)};
  }
  static void assign(std::vector<double>& x, const GValue* v) {
    x.clear();
    for (guint i = 0; i < gst_value_array_get_size(v); ++i) {
      GValue d = G_VALUE_INIT;
      g_value_init(&d, G_TYPE_DOUBLE);
      if (g_value_transform(gst_value_array_get_value(v, i), &d))
        x.push_back(g_value_get_double(&d));
      g_value_unset(&d);
    }
  }
  template <class E, std::enable_if_t<std::is_enum<E>::value, int> = 0>
  static void assign(E& x, const GValue* v) {
    x = static_cast<E>(g_value_get_enum(v));
  }
  static void fetch(const std::string& x, GValue* v) {
    g_value_set_string(v, x.empty() ? nullptr : x.c_str());
  }
  static void fetch(gint x, GValue* v) { g_value_set_int(v, x); }
  static void fetch(guint x, GValue* v) { g_value_set_uint(v, x); }
  static void fetch(guint64 x, GValue* v) { g_value_set_uint64(v, x); }
  static void fetch(const std::atomic<guint64>& x, GValue* v) { g_value_set_uint64(v, x.load()); }
  static void fetch(gdouble x, GValue* v) { g_value_set_double(v, x); }
  static void fetch(bool x, GValue* v) { g_value_set_boolean(v, x); }
  static void fetch(const Fraction& x, GValue* v) { gst_value_set_fraction(v, x.n, x.d); }
  static void fetch(const std::vector<double>& x, GValue* v) {
    for (double c : x) {
      GValue d = G_VALUE_INIT;
      g_value_init(&d, G_TYPE_DOUBLE);
      g_value_set_double(&d, c);
      gst_value_array_append_and_take_value(v, &d);
    }
  }
  template <class E, std::enable_if_t<std::is_enum<E>::value, int> = 0>
  static void fetch(E x, GValue* v) {
    g_value_set_enum(v, static_cast<gint>(x));
  }
  // The entry of property `id`, or null (warned) if it is not in the table.
  const Entry* find(GObject* obj, guint id, GParamSpec* ps) const {
    if (id >= 1 && id <= entries_.size()) return &entries_[id - 1];
    G_OBJECT_WARN_INVALID_PROPERTY_ID(obj, id, ps);
    return nullptr;
  }
  std::vector<Entry> entries_;
};

// A copy of the settings, taken under the object lock.
template <class S>
S snapshot(GstObject* obj, const S& s) {
  GST_OBJECT_LOCK(obj);
  S copy = s;
  GST_OBJECT_UNLOCK(obj);
  return copy;
}

// One member, read under the object lock (properties mutable in PLAYING).
template <class S, class T, class B, std::enable_if_t<std::is_base_of<B, S>::value, int> = 0>
T read_setting(GstObject* obj, const S& s, T B::*m) {
  GST_OBJECT_LOCK(obj);
  T copy = s.*m;
  GST_OBJECT_UNLOCK(obj);
  return copy;
}

// One member written under the object lock (a read-only statistic).
template <class S, class T, class B, std::enable_if_t<std::is_base_of<B, S>::value, int> = 0>
void write_setting(GstObject* obj, S& s, T B::*m, T value) {
  GST_OBJECT_LOCK(obj);
  s.*m = value;
  GST_OBJECT_UNLOCK(obj);
}

// A read-only count since the element was made (guint64).
inline GParamSpec* counter_spec(const char* name, const char* nick, const char* blurb) {
  return g_param_spec_uint64(name, nick, blurb, 0, G_MAXUINT64, 0,
                             static_cast<GParamFlags>(G_PARAM_READABLE | G_PARAM_STATIC_STRINGS));
}

// Flags of the elements' properties.
constexpr GParamFlags kReadWriteReady =
    static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_READY);
constexpr GParamFlags kReadWritePlaying = static_cast<GParamFlags>(
    G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS | GST_PARAM_MUTABLE_PLAYING);

}  // namespace lfgst

// The adding elements' example (gst-launch-1.0): two Chess cameras (row 4,
// columns 4 and 5), each through its lffragment into element `into`, which
// the example then declares.
#define LF_TWO_CAMERA_EXAMPLE(into)                                                           \
  "gst-launch-1.0 lfviewrequest rig=../shared/data/stanford-chess num-buffers=60 "            \
  "focal-surface=false ! tee name=t "                                                         \
  "t. ! queue ! a.request t. ! queue ! b.request lfcamsrc rig=../shared/data/stanford-chess " \
  "row=4 col=4 ! lffragment name=a rig=../shared/data/stanford-chess row=4 col=4 ! " into     \
  ". "                                                                                        \
  "lfcamsrc rig=../shared/data/stanford-chess row=4 col=5 ! lffragment name=b "               \
  "rig=../shared/data/stanford-chess row=4 col=5 ! " into ". "

// The GObject glue every element shares: set_property / get_property through
// the element's `props` table on `self->priv->settings`, and finalize
// deleting `self->priv`. PREFIX is the element's function prefix, CAST its
// instance cast macro.
#define LF_DEFINE_ELEMENT_GLUE(PREFIX, CAST)                                                   \
  static void PREFIX##_set_property(GObject* obj, guint id, const GValue* v, GParamSpec* ps) { \
    props.set(obj, CAST(obj)->priv->settings, id, v, ps);                                      \
    PREFIX##_property_set(obj, ps, v);                                                         \
  }                                                                                            \
  static void PREFIX##_get_property(GObject* obj, guint id, GValue* v, GParamSpec* ps) {       \
    props.get(obj, CAST(obj)->priv->settings, id, v, ps);                                      \
  }                                                                                            \
  static void PREFIX##_finalize(GObject* obj) {                                                \
    delete CAST(obj)->priv;                                                                    \
    G_OBJECT_CLASS(PREFIX##_parent_class)->finalize(obj);                                      \
  }

namespace lfgst {

// For live sources (lfcamsrc, lfviewrequest: frames leave at their capture
// or request time): the latency query answered as live with no latency.
// False for other queries (then the base class answers).
inline bool answer_live_latency(GstBaseSrc* src, GstQuery* q) {
  if (GST_QUERY_TYPE(q) != GST_QUERY_LATENCY || !gst_base_src_is_live(src)) return false;
  gst_query_set_latency(q, TRUE, 0, GST_CLOCK_TIME_NONE);
  return true;
}

// Live capture and request schedules cannot be repositioned: seeks are
// refused (logged), not accepted and left to stall the pipeline. True when
// `event` is a seek.
inline bool refuse_seek(GstElement* el, GstEvent* event) {
  if (GST_EVENT_TYPE(event) != GST_EVENT_SEEK) return false;
  GST_INFO_OBJECT(el, "refusing a seek: live light field streams are not seekable");
  return true;
}

// A registered GEnum type, made once.
inline GType enum_type(GType* type, const char* name, const GEnumValue* values) {
  if (g_once_init_enter(type)) g_once_init_leave(type, g_enum_register_static(name, values));
  return *type;
}

// Live sources (lfcamsrc, lfviewrequest): the live flag must be known before
// READY->PAUSED (live sources do not preroll), so it is applied when set.
inline void apply_is_live(GObject* obj, GParamSpec* ps, const GValue* v) {
  if (g_str_equal(ps->name, "is-live"))
    gst_base_src_set_live(GST_BASE_SRC(obj), g_value_get_boolean(v));
}

}  // namespace lfgst
