// GStreamer set-up shared by the element tests: the uninstalled plugin from
// the build tree and a private registry file.
#pragma once

#include <gst/gst.h>

#include <filesystem>
#include <functional>
#include <string>

#if defined(__SANITIZE_ADDRESS__)
#define LF_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LF_TEST_ASAN 1
#endif
#endif

#ifdef LF_TEST_ASAN
// Full malloc stacks for LeakSanitizer in the GStreamer tests: GLib leaks
// its first quark block on purpose once more than 2048 quarks exist
// (gquark.c; many installed plugins), and only a full stack shows that the
// block came from a library constructor (tests/lsan.supp: _dl_init).
// ASAN_OPTIONS from the environment still take precedence.
extern "C" const char* __asan_default_options() {
  return "fast_unwind_on_malloc=0";
}
#endif

namespace testing_lf {

inline void init_gstreamer_with_plugin() {
  g_setenv("GST_PLUGIN_PATH", LF_PLUGIN_DIR, TRUE);
  // One registry per build directory (a sanitizer build's plugin is not
  // loadable by another build's tests, nor by the plugin scanner).
  const std::string tag = std::to_string(std::hash<std::string>()(LF_PLUGIN_DIR));
  g_setenv("GST_REGISTRY",
           (std::filesystem::temp_directory_path() / ("lf-test-registry-" + tag + ".bin")).c_str(),
           TRUE);
#ifdef LF_TEST_ASAN
  // Load plugins in this (sanitized) process, and only the packages the
  // tests use (a faster scan, fewer quarks).
  g_setenv("GST_REGISTRY_FORK", "no", TRUE);
  g_setenv("GST_PLUGIN_LOADING_WHITELIST",
           "gstreamer:gst-plugins-base:gst-plugins-good:lightfield-gst", TRUE);
#endif
  gst_init(nullptr, nullptr);
}

// The debug text of an error (or warning) message, which it unrefs.
inline std::string take_error_debug(GstMessage* m) {
  GError* e = nullptr;
  gchar* dbg = nullptr;
  if (GST_MESSAGE_TYPE(m) == GST_MESSAGE_WARNING)
    gst_message_parse_warning(m, &e, &dbg);
  else
    gst_message_parse_error(m, &e, &dbg);
  std::string out = std::string(e ? e->message : "") + ": " + (dbg ? dbg : "");
  g_clear_error(&e);
  g_free(dbg);
  gst_message_unref(m);
  return out;
}

// Calls on(bytes, size) for every buffer that passes `pad`, on the
// streaming thread, the buffer mapped for reading (a buffer probe, removed
// with the pad).
inline void on_each_buffer(GstPad* pad, std::function<void(const guint8*, gsize)> on) {
  using Fn = std::function<void(const guint8*, gsize)>;
  gst_pad_add_probe(
      pad, GST_PAD_PROBE_TYPE_BUFFER,
      [](GstPad*, GstPadProbeInfo* info, gpointer data) {
        GstBuffer* b = GST_PAD_PROBE_INFO_BUFFER(info);
        GstMapInfo m;
        if (b && gst_buffer_map(b, &m, GST_MAP_READ)) {
          (*static_cast<Fn*>(data))(m.data, m.size);
          gst_buffer_unmap(b, &m);
        }
        return GST_PAD_PROBE_OK;
      },
      new Fn(std::move(on)), [](gpointer data) { delete static_cast<Fn*>(data); });
}

}  // namespace testing_lf
