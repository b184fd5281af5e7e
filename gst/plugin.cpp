// The lightfield plugin: lfcamsrc, lffragment, lfcompositor, lfviewrequest,
// the bins built from a rig, lfcamerahost and lfarray, lffragmentdemux
// (fragments routed to one pad per viewer), lfpartialsum (a camera host's
// fragments added up), lfrequestmux (viewers' requests joined in turn),
// lfrequestqueue (requests queued per viewer, load shed) and lflenticular.
// Package, version and origin come from the build (meson.build,
// meson_options.txt: package-name, package-origin) through config.h.
#include <gst/gst.h>

#include "config.h"

GST_ELEMENT_REGISTER_DECLARE(lfcamsrc);
GST_ELEMENT_REGISTER_DECLARE(lffragment);
GST_ELEMENT_REGISTER_DECLARE(lfcompositor);
GST_ELEMENT_REGISTER_DECLARE(lfviewrequest);
GST_ELEMENT_REGISTER_DECLARE(lfcamerahost);
GST_ELEMENT_REGISTER_DECLARE(lfarray);
GST_ELEMENT_REGISTER_DECLARE(lffragmentdemux);
GST_ELEMENT_REGISTER_DECLARE(lfpartialsum);
GST_ELEMENT_REGISTER_DECLARE(lfrequestmux);
GST_ELEMENT_REGISTER_DECLARE(lfrequestqueue);
GST_ELEMENT_REGISTER_DECLARE(lflenticular);

static gboolean plugin_init(GstPlugin* plugin) {
  gboolean ok = FALSE;
  ok |= GST_ELEMENT_REGISTER(lfcamsrc, plugin);
  ok |= GST_ELEMENT_REGISTER(lffragment, plugin);
  ok |= GST_ELEMENT_REGISTER(lfcompositor, plugin);
  ok |= GST_ELEMENT_REGISTER(lfviewrequest, plugin);
  ok |= GST_ELEMENT_REGISTER(lfcamerahost, plugin);
  ok |= GST_ELEMENT_REGISTER(lfarray, plugin);
  ok |= GST_ELEMENT_REGISTER(lffragmentdemux, plugin);
  ok |= GST_ELEMENT_REGISTER(lfpartialsum, plugin);
  ok |= GST_ELEMENT_REGISTER(lfrequestmux, plugin);
  ok |= GST_ELEMENT_REGISTER(lfrequestqueue, plugin);
  ok |= GST_ELEMENT_REGISTER(lflenticular, plugin);
  return ok;
}

GST_PLUGIN_DEFINE(GST_VERSION_MAJOR, GST_VERSION_MINOR, lightfield,
                  "Distributed light field camera (Yang et al. 2002): cameras, fragments, "
                  "compositor, view requests",
                  plugin_init, VERSION, GST_LICENSE, GST_PACKAGE_NAME, GST_PACKAGE_ORIGIN)
