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

static void on_decoded_pad(GstElement*, GstPad* pad, gpointer convert) {
  GstCaps* caps = gst_pad_get_current_caps(pad);
  if (!caps) caps = gst_pad_query_caps(pad, nullptr);
  const bool video =
      caps && gst_caps_get_size(caps) > 0 &&
      g_str_has_prefix(gst_structure_get_name(gst_caps_get_structure(caps, 0)), "video/");
  if (caps) gst_caps_unref(caps);
  GstPad* sink = gst_element_get_static_pad(GST_ELEMENT(convert), "sink");
  if (video && !gst_pad_is_linked(sink)) gst_pad_link(pad, sink);
  gst_object_unref(sink);
}

void link_decoded_video(GstElement* decoder, GstElement* convert) {
  g_signal_connect(decoder, "pad-added", G_CALLBACK(on_decoded_pad), convert);
}

}  // namespace lfgst
