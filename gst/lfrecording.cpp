#include "lfrecording.h"

#include <stdexcept>

#include "lfguard.h"

namespace lfgst {

static GstElement* make(const char* factory, const std::string& name) {
  return make_element(factory, name.c_str());
}

void link_or_throw(GstElement* a, GstElement* b, const std::string& what) {
  if (!gst_element_link(a, b)) throw std::runtime_error("cannot link " + what);
}

GstElement* add_playback(const Adopt& adopt, std::vector<GstElement*>& deferred,
                         const std::string& file, const lf::Camera& cam, const std::string& id) {
  GstElement* src = adopt(make("filesrc", "playback" + id));
  GstElement* dec = adopt(make("decodebin", "decode" + id));
  GstElement* convert = adopt(make("videoconvert", "convert" + id));
  GstElement* filter = adopt(make("capsfilter", "rgba" + id));
  GstElement* sync = adopt(make("clocksync", "schedule" + id));
  g_object_set(src, "location", file.c_str(), nullptr);
  GstCaps* caps =
      gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, "RGBA", "width", G_TYPE_INT,
                          cam.width, "height", G_TYPE_INT, cam.height, nullptr);
  g_object_set(filter, "caps", caps, nullptr);
  gst_caps_unref(caps);
  // The decoder's pads appear only when it runs, so the bin cannot order it
  // after the converter: started before it, it would push into a converter
  // still in READY, be refused (FLUSHING) and stop without an error. They
  // start when the bin is PAUSED (lfcamerahost).
  gst_element_set_locked_state(dec, TRUE);
  gst_element_set_locked_state(src, TRUE);
  deferred.insert(deferred.end(), {dec, src});
  link_or_throw(src, dec, "the playback of camera " + id);
  lfgst::link_decoded_video(dec, convert);
  link_or_throw(convert, filter, "the playback of camera " + id);
  link_or_throw(filter, sync, "the playback of camera " + id);
  return sync;
}

GstElement* add_recorder(const Adopt& adopt, GstElement* cam, const std::string& file, gint quality,
                         const std::string& id) {
  GstElement* tee = adopt(make("tee", "split" + id));
  GstElement* q = adopt(make("queue", "record-queue" + id));
  GstElement* convert = adopt(make("videoconvert", "record-convert" + id));
  GstElement* filter = adopt(make("capsfilter", "record-rgb" + id));
  GstElement* mux = adopt(make("matroskamux", "mux" + id));
  GstElement* sink = adopt(make("filesink", "record" + id));
  // The recording must not lose frames: up to 2 s of them wait for the disk.
  g_object_set(q, "max-size-buffers", 0, "max-size-bytes", 0, "max-size-time",
               static_cast<guint64>(2 * GST_SECOND), nullptr);
  GstCaps* caps = gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, "RGB", nullptr);
  g_object_set(filter, "caps", caps, nullptr);
  gst_caps_unref(caps);
  g_object_set(mux, "timecodescale", static_cast<gint64>(1), nullptr);
  g_object_set(sink, "location", file.c_str(), "async", FALSE, nullptr);
  const std::string what = "the recording of camera " + id;
  link_or_throw(cam, tee, what);
  link_or_throw(tee, q, what);
  link_or_throw(q, convert, what);
  link_or_throw(convert, filter, what);
  GstElement* last = filter;
  if (quality > 0) {
    GstElement* jpeg = adopt(make("jpegenc", "record-jpeg" + id));
    g_object_set(jpeg, "quality", quality, nullptr);
    link_or_throw(filter, jpeg, what);
    last = jpeg;
  }
  link_or_throw(last, mux, what);
  link_or_throw(mux, sink, what);
  return tee;
}

}  // namespace lfgst
