// GStreamer set-up shared by the element tests: the uninstalled plugin from
// the build tree and a private registry file.
#pragma once

#include <gst/gst.h>

#include <filesystem>

namespace testing_lf {

inline void init_gstreamer_with_plugin() {
  g_setenv("GST_PLUGIN_PATH", LF_PLUGIN_DIR, TRUE);
  g_setenv("GST_REGISTRY",
           (std::filesystem::temp_directory_path() / "lf-test-registry.bin").c_str(), TRUE);
  gst_init(nullptr, nullptr);
}

}  // namespace testing_lf
