// The lightfield plugin: lfcamsrc, lffragment, lfcompositor, lfviewrequest.
#include <gst/gst.h>

gboolean lf_cam_src_register(GstPlugin* plugin);
gboolean lf_fragment_register(GstPlugin* plugin);
gboolean lf_compositor_register(GstPlugin* plugin);
gboolean lf_view_request_register(GstPlugin* plugin);

static gboolean plugin_init(GstPlugin* plugin) {
  return lf_cam_src_register(plugin) && lf_fragment_register(plugin) &&
         lf_compositor_register(plugin) && lf_view_request_register(plugin);
}

#define PACKAGE "lightfield-gst"
GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, lightfield,
                  "Distributed light field camera (Yang et al. 2002): cameras, fragments, "
                  "compositor, view requests",
                  plugin_init, "0.1.0", "LGPL", "lightfield-gst",
                  "https://example.invalid/lightfield-gst")
