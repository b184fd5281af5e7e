#include "lfforward.h"

#include <string>

namespace lfgst {

// A copy of a child's property (same name, type, range, default and text),
// readable, writable and changeable in NULL or READY on the bin (the bin
// sets it on its children when it builds them); the text says so where the
// child itself takes changes while playing.
static GParamSpec* copy_spec(GParamSpec* t) {
  const GParamFlags rw = static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_NAME |
                                                  G_PARAM_STATIC_NICK | GST_PARAM_MUTABLE_READY);
  const gchar* n = g_param_spec_get_name(t);
  const gchar* nick = g_param_spec_get_nick(t);
  // GLib copies a blurb without G_PARAM_STATIC_BLURB; this one lives as long
  // as the class.
  std::string text = g_param_spec_get_blurb(t);
  if (t->flags & GST_PARAM_MUTABLE_PLAYING)
    text +=
        ". On this bin: read when the bin builds its children (NULL to READY); change it "
        "while playing on the child element";
  const gchar* blurb = text.c_str();
  if (G_IS_PARAM_SPEC_ENUM(t))
    return g_param_spec_enum(n, nick, blurb, t->value_type, G_PARAM_SPEC_ENUM(t)->default_value,
                             rw);
  if (G_IS_PARAM_SPEC_BOOLEAN(t))
    return g_param_spec_boolean(n, nick, blurb, G_PARAM_SPEC_BOOLEAN(t)->default_value, rw);
  if (G_IS_PARAM_SPEC_INT(t)) {
    auto* i = G_PARAM_SPEC_INT(t);
    return g_param_spec_int(n, nick, blurb, i->minimum, i->maximum, i->default_value, rw);
  }
  if (G_IS_PARAM_SPEC_UINT(t)) {
    auto* i = G_PARAM_SPEC_UINT(t);
    return g_param_spec_uint(n, nick, blurb, i->minimum, i->maximum, i->default_value, rw);
  }
  if (G_IS_PARAM_SPEC_UINT64(t)) {
    auto* i = G_PARAM_SPEC_UINT64(t);
    return g_param_spec_uint64(n, nick, blurb, i->minimum, i->maximum, i->default_value, rw);
  }
  if (G_IS_PARAM_SPEC_DOUBLE(t)) {
    auto* d = G_PARAM_SPEC_DOUBLE(t);
    return g_param_spec_double(n, nick, blurb, d->minimum, d->maximum, d->default_value, rw);
  }
  if (GST_IS_PARAM_SPEC_FRACTION(t)) {
    auto* f = GST_PARAM_SPEC_FRACTION(t);
    return gst_param_spec_fraction(n, nick, blurb, f->min_num, f->min_den, f->max_num, f->max_den,
                                   f->def_num, f->def_den, rw);
  }
  g_error("lfforward: cannot forward property %s of type %s", n, g_type_name(t->value_type));
  return nullptr;
}

void install_forwards(GObjectClass* oc, guint id, const Forward* begin, const Forward* end) {
  for (const Forward* f = begin; f != end; ++f) {
    auto* child = static_cast<GObjectClass*>(g_type_class_ref(f->child()));
    GParamSpec* target = g_object_class_find_property(child, f->name);
    g_assert(target);
    g_object_class_install_property(oc, id++, copy_spec(target));
    g_type_class_unref(child);
  }
}

bool ForwardedValues::set(size_t i, const GValue* v) {
  if (i >= values_.size()) return false;
  if (G_IS_VALUE(&values_[i])) g_value_unset(&values_[i]);
  g_value_init(&values_[i], G_VALUE_TYPE(v));
  g_value_copy(v, &values_[i]);
  set_[i] = true;
  return true;
}

bool ForwardedValues::get(size_t i, GValue* v, GParamSpec* ps) const {
  if (i >= values_.size()) return false;
  if (set_[i])
    g_value_copy(&values_[i], v);
  else
    g_param_value_set_default(ps, v);
  return true;
}

void ForwardedValues::copy(const std::vector<Forward>& fw, Copy* out) const {
  for (size_t i = 0; i < fw.size() && i < values_.size(); ++i) {
    if (!set_[i]) continue;
    out->values.push_back({fw[i], G_VALUE_INIT});
    g_value_init(&out->values.back().value, G_VALUE_TYPE(&values_[i]));
    g_value_copy(&values_[i], &out->values.back().value);
  }
}

}  // namespace lfgst
