// Bin properties forwarded to children (lfcamerahost, lfarray): a copy of a
// child element's property on the bin, set on every child of that kind
// when the bin builds them.
#pragma once

#include <gst/gst.h>

#include <vector>

namespace lfgst {

// A bin property that is set on each child of one kind.
struct Forward {
  GType (*child)();
  const char* name;
};

// Installs copies of the children's properties [begin, end) on `oc`, with
// ids from `id` on: same name, type, range, default and text, readable,
// writable and changeable in NULL or READY on the bin; the text says so
// where the child itself takes changes while playing.
void install_forwards(GObjectClass* oc, guint id, const Forward* begin, const Forward* end);

// The values of a bin's forwarded properties, only those set (the caller
// holds the object lock around each call).
class ForwardedValues {
 public:
  explicit ForwardedValues(size_t n) : values_(n), set_(n, false) {
    for (GValue& v : values_) v = G_VALUE_INIT;
  }
  ~ForwardedValues() {
    for (GValue& v : values_)
      if (G_IS_VALUE(&v)) g_value_unset(&v);
  }
  ForwardedValues(const ForwardedValues&) = delete;
  ForwardedValues& operator=(const ForwardedValues&) = delete;
  // set_property / get_property of forwarded property `i`; false when out
  // of range. get() gives the property's default until it is set.
  bool set(size_t i, const GValue* v);
  bool get(size_t i, GValue* v, GParamSpec* ps) const;
  // A copy of the values set, each with its Forward (fw[i] is property i's).
  struct Set {
    Forward forward;
    GValue value;
  };
  class Copy {
   public:
    std::vector<Set> values;
    Copy() = default;
    Copy(const Copy&) = delete;
    Copy& operator=(const Copy&) = delete;
    ~Copy() {
      for (Set& s : values) g_value_unset(&s.value);
    }
  };
  void copy(const std::vector<Forward>& fw, Copy* out) const;

 private:
  std::vector<GValue> values_;
  std::vector<bool> set_;
};

}  // namespace lfgst
