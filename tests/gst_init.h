// GStreamer set-up shared by the element tests: the uninstalled plugin from
// the build tree and a private registry file.
#pragma once

#include <gst/gst.h>

#include <filesystem>
#include <functional>
#include <string>

namespace testing_lf {

inline void init_gstreamer_with_plugin() {
  g_setenv("GST_PLUGIN_PATH", LF_PLUGIN_DIR, TRUE);
  // One registry per build directory (a sanitizer build's plugin is not
  // loadable by another build's tests, nor by the plugin scanner).
  const std::string tag = std::to_string(std::hash<std::string>()(LF_PLUGIN_DIR));
  g_setenv("GST_REGISTRY",
           (std::filesystem::temp_directory_path() / ("lf-test-registry-" + tag + ".bin")).c_str(),
           TRUE);
#if defined(__SANITIZE_ADDRESS__)
#define LF_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define LF_TEST_ASAN 1
#endif
#endif
#ifdef LF_TEST_ASAN
  // Load plugins in this (sanitized) process, and only the packages the
  // tests use: loading every installed plugin creates more than 2048 GLib
  // quarks, and GLib then leaks its first quark block on purpose (gquark.c),
  // which LeakSanitizer's shallow stacks cannot tell from a real leak.
  g_setenv("GST_REGISTRY_FORK", "no", TRUE);
  g_setenv("GST_PLUGIN_LOADING_WHITELIST",
           "gstreamer:gst-plugins-base:gst-plugins-good:lightfield-gst", TRUE);
#endif
  gst_init(nullptr, nullptr);
}

}  // namespace testing_lf
