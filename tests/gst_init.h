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
  g_setenv("GST_REGISTRY_FORK", "no", TRUE);  // load plugins in this (sanitized) process
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  g_setenv("GST_REGISTRY_FORK", "no", TRUE);
#endif
#endif
  gst_init(nullptr, nullptr);
}

}  // namespace testing_lf
