#include "lfguard.h"

#include <stdexcept>
#include <string>

namespace lfgst {

GQuark error_quark() {
  return g_quark_from_static_string("lightfield-error-quark");
}

GstElement* make_element(const char* factory, const char* name) {
  GstElement* e = gst_element_factory_make(factory, name);
  if (!e) throw std::runtime_error(std::string("GStreamer element '") + factory + "' is missing");
  return e;
}

}  // namespace lfgst
