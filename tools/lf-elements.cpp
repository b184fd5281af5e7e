// lf-elements: the element reference (docs/elements.md) printed from the
// registered plugin, so that the page cannot drift from the code: every
// element's metadata (long name, klass, description, the "Example" and
// "Events" keys that gst-inspect-1.0 prints too), pad templates and their
// caps, the element's own properties (type, range or values, default,
// access, the states in which a change takes effect) and its own signals.
// Properties and signals inherited from GStreamer's base classes (GstBin,
// GstAggregator, GstBaseSrc...) are named, not repeated: gst-inspect-1.0
// lists them. The test `elements_doc` fails when docs/elements.md differs
// from what this prints.
#include <gst/gst.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <type_traits>
#include <vector>

namespace {

const char* kSummary =
    "Prints the reference of the lightfield plugin's elements as markdown (docs/elements.md),\n"
    "from the plugin as GStreamer registers it (GST_PLUGIN_PATH, or --plugin).";

std::string fmt_double(double v) {
  char buf[64];
  g_ascii_formatd(buf, sizeof buf, "%.6g", v);
  return buf;
}

// Markdown table cells: no pipes or newlines.
std::string cell(std::string s) {
  std::string out;
  for (char c : s) {
    if (c == '|')
      out += "\\|";
    else if (c == '\n')
      out += ' ';
    else
      out += c;
  }
  return out;
}

std::string type_name(GParamSpec* p) {
  const GType t = G_PARAM_SPEC_VALUE_TYPE(p);
  switch (G_TYPE_FUNDAMENTAL(t)) {
    case G_TYPE_BOOLEAN:
      return "boolean";
    case G_TYPE_INT:
      return "int";
    case G_TYPE_UINT:
      return "uint";
    case G_TYPE_INT64:
      return "int64";
    case G_TYPE_UINT64:
      return "uint64";
    case G_TYPE_DOUBLE:
      return "double";
    case G_TYPE_FLOAT:
      return "float";
    case G_TYPE_STRING:
      return "string";
    case G_TYPE_ENUM:
      return std::string("enum ") + g_type_name(t);
    case G_TYPE_FLAGS:
      return std::string("flags ") + g_type_name(t);
    default:
      break;
  }
  if (t == GST_TYPE_FRACTION) return "fraction";
  if (t == GST_TYPE_ARRAY) {
    GParamSpec* e = GST_PARAM_SPEC_ARRAY_LIST(p)->element_spec;
    return std::string("array of ") + (e ? type_name(e) : "values") + " (`<a, b, ...>`)";
  }
  return g_type_name(t);
}

// "min to max" of a numeric GParamSpec (its minimum and maximum fields).
template <typename Spec>
std::string bounds(const Spec* s) {
  if constexpr (std::is_floating_point_v<decltype(s->minimum)>)
    return fmt_double(s->minimum) + " to " + fmt_double(s->maximum);
  else
    return std::to_string(s->minimum) + " to " + std::to_string(s->maximum);
}

// "`nick`: NAME; ..." of an enum's or a flags type's values.
template <typename Value>
std::string values(const Value* v, guint n) {
  std::string out;
  for (guint i = 0; i < n; ++i)
    out += std::string(i ? "; `" : "`") + v[i].value_nick + "`: " + v[i].value_name;
  return out;
}

std::string range(GParamSpec* p) {
  const GType t = G_PARAM_SPEC_VALUE_TYPE(p);
  switch (G_TYPE_FUNDAMENTAL(t)) {
    case G_TYPE_INT:
      return bounds(G_PARAM_SPEC_INT(p));
    case G_TYPE_UINT:
      return bounds(G_PARAM_SPEC_UINT(p));
    case G_TYPE_INT64:
      return bounds(G_PARAM_SPEC_INT64(p));
    case G_TYPE_UINT64:
      return bounds(G_PARAM_SPEC_UINT64(p));
    case G_TYPE_DOUBLE:
      return bounds(G_PARAM_SPEC_DOUBLE(p));
    case G_TYPE_FLOAT:
      return bounds(G_PARAM_SPEC_FLOAT(p));
    case G_TYPE_ENUM: {
      GEnumClass* k = G_ENUM_CLASS(g_type_class_ref(t));
      std::string out = values(k->values, k->n_values);
      g_type_class_unref(k);
      return out;
    }
    case G_TYPE_FLAGS: {
      GFlagsClass* k = G_FLAGS_CLASS(g_type_class_ref(t));
      std::string out = values(k->values, k->n_values);
      g_type_class_unref(k);
      return out;
    }
    default:
      break;
  }
  if (t == GST_TYPE_FRACTION) {
    auto* s = GST_PARAM_SPEC_FRACTION(p);
    return std::to_string(s->min_num) + "/" + std::to_string(s->min_den) + " to " +
           std::to_string(s->max_num) + "/" + std::to_string(s->max_den);
  }
  return "";
}

std::string default_value(GParamSpec* p) {
  const GValue* v = g_param_spec_get_default_value(p);
  const GType t = G_VALUE_TYPE(v);
  switch (G_TYPE_FUNDAMENTAL(t)) {
    case G_TYPE_BOOLEAN:
      return g_value_get_boolean(v) ? "true" : "false";
    case G_TYPE_INT:
      return std::to_string(g_value_get_int(v));
    case G_TYPE_UINT:
      return std::to_string(g_value_get_uint(v));
    case G_TYPE_INT64:
      return std::to_string(g_value_get_int64(v));
    case G_TYPE_UINT64:
      return std::to_string(g_value_get_uint64(v));
    case G_TYPE_DOUBLE:
      return fmt_double(g_value_get_double(v));
    case G_TYPE_FLOAT:
      return fmt_double(g_value_get_float(v));
    case G_TYPE_STRING: {
      const char* s = g_value_get_string(v);
      if (!s) return "(none)";
      // A default under the user's cache folder is named as such, so the page
      // is the same for every user.
      std::string str = s;
      const std::string cache = g_get_user_cache_dir();
      if (str.rfind(cache, 0) == 0) str = "$XDG_CACHE_HOME" + str.substr(cache.size());
      return "\"" + str + "\"";
    }
    case G_TYPE_ENUM: {
      GEnumClass* k = G_ENUM_CLASS(g_type_class_ref(t));
      GEnumValue* e = g_enum_get_value(k, g_value_get_enum(v));
      std::string out = e ? e->value_nick : std::to_string(g_value_get_enum(v));
      g_type_class_unref(k);
      return out;
    }
    default:
      break;
  }
  if (t == GST_TYPE_FRACTION)
    return std::to_string(gst_value_get_fraction_numerator(v)) + "/" +
           std::to_string(gst_value_get_fraction_denominator(v));
  gchar* s = gst_value_serialize(v);
  std::string out = s ? s : "(none)";
  g_free(s);
  return out.empty() ? "(none)" : out;
}

std::string access(GParamSpec* p) {
  std::string a;
  if (p->flags & G_PARAM_READABLE) a += "read";
  if (p->flags & G_PARAM_WRITABLE) a += a.empty() ? "write" : "/write";
  return a;
}

// When a written value takes effect (GST_PARAM_MUTABLE_*; GObject properties
// without such a flag are read when the element starts).
std::string changeable(GParamSpec* p) {
  if (!(p->flags & G_PARAM_WRITABLE)) return "-";
  if (p->flags & GST_PARAM_MUTABLE_PLAYING) return "any state";
  if (p->flags & GST_PARAM_MUTABLE_PAUSED) return "up to PAUSED";
  return "NULL or READY";
}

// The properties that `type` and its ancestors of this plugin install (not
// GStreamer's base classes').
std::vector<GParamSpec*> own_properties(GType type) {
  GObjectClass* k = G_OBJECT_CLASS(g_type_class_ref(type));
  guint n = 0;
  GParamSpec** all = g_object_class_list_properties(k, &n);
  std::vector<GParamSpec*> out;
  for (guint i = 0; i < n; ++i)
    if (g_str_has_prefix(g_type_name(all[i]->owner_type), "Lf")) out.push_back(all[i]);
  g_free(all);
  std::sort(out.begin(), out.end(),
            [](GParamSpec* a, GParamSpec* b) { return g_strcmp0(a->name, b->name) < 0; });
  g_type_class_unref(k);
  return out;
}

void print_properties(const std::vector<GParamSpec*>& props) {
  std::printf("| property | type | range or values | default | access | takes effect in |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (GParamSpec* p : props)
    std::printf("| `%s` | %s | %s | %s | %s | %s |\n", p->name, cell(type_name(p)).c_str(),
                cell(range(p)).c_str(), cell(default_value(p)).c_str(), access(p).c_str(),
                changeable(p).c_str());
  std::printf("\n");
  for (GParamSpec* p : props) std::printf("- `%s`: %s\n", p->name, g_param_spec_get_blurb(p));
  std::printf("\n");
}

// The nearest ancestor that GStreamer (not this plugin) defines.
GType gstreamer_base(GType type) {
  GType t = g_type_parent(type);
  while (t && g_str_has_prefix(g_type_name(t), "Lf")) t = g_type_parent(t);
  return t;
}

void print_signals(GType type) {
  guint n = 0;
  guint* ids = g_signal_list_ids(type, &n);
  std::vector<GSignalQuery> qs(n);
  for (guint i = 0; i < n; ++i) g_signal_query(ids[i], &qs[i]);
  g_free(ids);
  if (qs.empty()) return;
  std::sort(qs.begin(), qs.end(), [](const GSignalQuery& a, const GSignalQuery& b) {
    return g_strcmp0(a.signal_name, b.signal_name) < 0;
  });
  std::printf("**Signals**\n\n");
  for (const GSignalQuery& q : qs) {
    std::string args = "GstElement* self";
    for (guint i = 0; i < q.n_params; ++i)
      args += std::string(", ") + g_type_name(q.param_types[i] & ~G_SIGNAL_TYPE_STATIC_SCOPE);
    std::printf("- `%s` (%s): `%s (%s)`\n", q.signal_name,
                (q.signal_flags & G_SIGNAL_ACTION) ? "action" : "emitted",
                g_type_name(q.return_type), args.c_str());
  }
  std::printf("\n");
}

const char* presence(GstPadPresence p) {
  switch (p) {
    case GST_PAD_ALWAYS:
      return "always";
    case GST_PAD_SOMETIMES:
      return "sometimes";
    default:
      return "request";
  }
}

void print_pads(GstElementFactory* f) {
  std::printf("**Pads**\n\n| pad | direction | presence | caps |\n|---|---|---|---|\n");
  std::vector<GstStaticPadTemplate*> pads;
  for (const GList* l = gst_element_factory_get_static_pad_templates(f); l; l = l->next)
    pads.push_back(static_cast<GstStaticPadTemplate*>(l->data));
  // The registry's order differs between a fresh load and its cache: sink
  // pads first, then source pads, each by name.
  std::sort(pads.begin(), pads.end(), [](GstStaticPadTemplate* a, GstStaticPadTemplate* b) {
    if (a->direction != b->direction) return a->direction == GST_PAD_SINK;
    return g_strcmp0(a->name_template, b->name_template) < 0;
  });
  for (GstStaticPadTemplate* t : pads) {
    GstCaps* caps = gst_static_caps_get(&t->static_caps);
    std::string c;
    for (guint i = 0; i < gst_caps_get_size(caps); ++i) {
      gchar* s = gst_structure_to_string(gst_caps_get_structure(caps, i));
      c += std::string(i ? "; " : "") + "`" + s + "`";
      g_free(s);
    }
    if (gst_caps_is_any(caps)) c = "ANY";
    gst_caps_unref(caps);
    std::printf("| `%s` | %s | %s | %s |\n", t->name_template,
                t->direction == GST_PAD_SRC ? "src" : "sink", presence(t->presence),
                cell(c).c_str());
  }
  std::printf("\n");
}

void print_element(GstElementFactory* f) {
  const char* name = gst_plugin_feature_get_name(GST_PLUGIN_FEATURE(f));
  GstElement* e = gst_element_factory_create(f, nullptr);  // loads the type
  const GType type = gst_element_factory_get_element_type(f);
  std::printf("## %s\n\n", name);
  std::printf("**%s** (`%s`; a %s)\n\n",
              gst_element_factory_get_metadata(f, GST_ELEMENT_METADATA_LONGNAME),
              gst_element_factory_get_metadata(f, GST_ELEMENT_METADATA_KLASS),
              g_type_name(gstreamer_base(type)));
  std::printf("%s.\n\n", gst_element_factory_get_metadata(f, GST_ELEMENT_METADATA_DESCRIPTION));
  if (const char* ex = gst_element_factory_get_metadata(f, "Example"))
    std::printf("```sh\n%s\n```\n\n", ex);
  print_pads(f);
  std::vector<GParamSpec*> props = own_properties(type);
  std::printf("**Properties** (besides those of %s)\n\n", g_type_name(gstreamer_base(type)));
  print_properties(props);
  // Request pads of our own pad type carry properties of their own.
  std::vector<GstStaticPadTemplate*> templates;
  for (const GList* l = gst_element_factory_get_static_pad_templates(f); l; l = l->next)
    templates.push_back(static_cast<GstStaticPadTemplate*>(l->data));
  std::sort(templates.begin(), templates.end(),
            [](GstStaticPadTemplate* a, GstStaticPadTemplate* b) {
              return g_strcmp0(a->name_template, b->name_template) < 0;
            });
  for (GstStaticPadTemplate* t : templates) {
    GstPadTemplate* pt =
        gst_element_class_get_pad_template(GST_ELEMENT_GET_CLASS(e), t->name_template);
    GType pad_type = pt ? GST_PAD_TEMPLATE_GTYPE(pt) : G_TYPE_NONE;
    if (pad_type == G_TYPE_NONE || !g_str_has_prefix(g_type_name(pad_type), "Lf")) continue;
    std::vector<GParamSpec*> pp = own_properties(pad_type);
    if (pp.empty()) continue;
    std::printf("**Properties of the `%s` pads**\n\n", t->name_template);
    print_properties(pp);
  }
  print_signals(type);
  if (const char* ev = gst_element_factory_get_metadata(f, "Events"))
    std::printf("**Events and messages**\n\n%s\n\n", ev);
  gst_object_unref(e);
}

}  // namespace

int main(int argc, char** argv) {
  gchar* plugin_file = nullptr;
  gchar* out_file = nullptr;
  const GOptionEntry entries[] = {
      {"plugin", 0, 0, G_OPTION_ARG_FILENAME, &plugin_file,
       "Load the plugin from this file (default: the registry's 'lightfield')", "FILE"},
      {"out", 'o', 0, G_OPTION_ARG_FILENAME, &out_file, "Write here (default: standard output)",
       "FILE"},
      {nullptr, 0, 0, G_OPTION_ARG_NONE, nullptr, nullptr, nullptr}};
  GOptionContext* ctx = g_option_context_new(nullptr);
  g_option_context_set_summary(ctx, kSummary);
  g_option_context_add_main_entries(ctx, entries, nullptr);
  g_option_context_add_group(ctx, gst_init_get_option_group());
  GError* err = nullptr;
  if (!g_option_context_parse(ctx, &argc, &argv, &err)) {
    std::fprintf(stderr, "lf-elements: %s\n", err->message);
    return 2;
  }
  g_option_context_free(ctx);
  GstPlugin* plugin = plugin_file ? gst_plugin_load_file(plugin_file, &err)
                                  : gst_registry_find_plugin(gst_registry_get(), "lightfield");
  if (!plugin) {
    std::fprintf(stderr, "lf-elements: cannot load the lightfield plugin: %s\n",
                 err ? err->message : "not in the registry (set GST_PLUGIN_PATH or --plugin)");
    return 1;
  }
  if (out_file && !std::freopen(out_file, "w", stdout)) {
    std::fprintf(stderr, "lf-elements: cannot write %s\n", out_file);
    return 1;
  }
  const char* pname = gst_plugin_get_name(plugin);
  std::printf("# Element reference\n\n");
  std::printf(
      "Generated by `tools/lf-elements` from the registered plugin `%s` (%s); do not edit: the "
      "test `elements_doc` fails when this page differs from what the tool prints. Regenerate "
      "with `GST_PLUGIN_PATH=build/gst build/tools/lf-elements -o docs/elements.md`. "
      "`gst-inspect-1.0 ELEMENT` shows the same and the properties inherited from GStreamer's "
      "base classes.\n\n",
      pname, gst_plugin_get_description(plugin));
  GList* features = gst_registry_get_feature_list_by_plugin(gst_registry_get(), pname);
  std::vector<GstElementFactory*> elements;
  for (GList* l = features; l; l = l->next)
    if (GST_IS_ELEMENT_FACTORY(l->data)) elements.push_back(GST_ELEMENT_FACTORY(l->data));
  std::sort(elements.begin(), elements.end(), [](GstElementFactory* a, GstElementFactory* b) {
    return g_strcmp0(gst_plugin_feature_get_name(GST_PLUGIN_FEATURE(a)),
                     gst_plugin_feature_get_name(GST_PLUGIN_FEATURE(b))) < 0;
  });
  std::printf("| element | klass | what it does |\n|---|---|---|\n");
  for (GstElementFactory* f : elements) {
    const char* n = gst_plugin_feature_get_name(GST_PLUGIN_FEATURE(f));
    std::printf("| [`%s`](#%s) | %s | %s |\n", n, n,
                gst_element_factory_get_metadata(f, GST_ELEMENT_METADATA_KLASS),
                gst_element_factory_get_metadata(f, GST_ELEMENT_METADATA_LONGNAME));
  }
  std::printf("\n");
  for (GstElementFactory* f : elements) print_element(f);
  gst_plugin_feature_list_free(features);
  gst_object_unref(plugin);
  std::fflush(stdout);
  return 0;
}
