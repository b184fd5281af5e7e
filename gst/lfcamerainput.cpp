#include "lfcamerainput.h"

#include <gst/app/gstappsink.h>
#include <gst/video/video.h>

#include <stdexcept>
#include <utility>

#include "lfguard.h"

namespace lfgst {
namespace {

// Every video decoder inside decodebin: the first frame it cannot decode is
// an error (max-errors 0), or, with skip-bad-frames, a warning (no limit).
void on_decoder_element(GstBin*, GstBin*, GstElement* e, gpointer skip) {
  if (GST_IS_VIDEO_DECODER(e))
    g_object_set(e, "max-errors", GPOINTER_TO_INT(skip) ? -1 : 0, nullptr);
}

}  // namespace

// With skip-bad-frames, the pipeline's warnings (a decoder's skipped frame),
// in the decoding thread as they are posted: kept for take_skipped(), never
// dropped unseen.
GstBusSyncReply DecodedInput::on_message(GstBus*, GstMessage* m, gpointer data) {
  auto* self = static_cast<DecodedInput*>(data);
  if (GST_MESSAGE_TYPE(m) != GST_MESSAGE_WARNING || !self->o_.skip_bad_frames) return GST_BUS_PASS;
  GError* e = nullptr;
  gst_message_parse_warning(m, &e, nullptr);
  std::lock_guard<std::mutex> l(self->lock_);
  self->skipped_.push_back(self->o_.location + ": " + (e ? e->message : "not decoded"));
  g_clear_error(&e);
  return GST_BUS_DROP;
}

DecodedInput::DecodedInput(const Options& o) : o_(o) {
  pipe_ = gst_pipeline_new(nullptr);
  GstBus* bus = gst_element_get_bus(pipe_);
  gst_bus_set_sync_handler(bus, on_message, this, nullptr);
  gst_object_unref(bus);
  GstElement* convert = make_element("videoconvert");
  GstElement* scale = make_element("videoscale");
  GstElement* filter = make_element("capsfilter");
  GstElement* app = make_element("appsink");
  GstCaps* caps = gst_caps_new_simple("video/x-raw", "format", G_TYPE_STRING, "RGBA", "width",
                                      G_TYPE_INT, o.width, "height", G_TYPE_INT, o.height,
                                      "pixel-aspect-ratio", GST_TYPE_FRACTION, 1, 1, nullptr);
  g_object_set(filter, "caps", caps, nullptr);
  gst_caps_unref(caps);
  g_object_set(app, "sync", FALSE, "max-buffers", 2, "drop", o.v4l2, nullptr);
  gst_bin_add_many(GST_BIN(pipe_), convert, scale, filter, app, nullptr);
  gst_element_link_many(convert, scale, filter, app, nullptr);
  sink_ = GST_ELEMENT(gst_object_ref(app));
  if (o.v4l2) {
    GstElement* src = make_element("v4l2src");
    g_object_set(src, "device", o.device.c_str(), nullptr);
    gst_bin_add(GST_BIN(pipe_), src);
    gst_element_link(src, convert);
  } else if (o.location.find('%') != std::string::npos) {
    GstElement* src = make_element("multifilesrc");
    GstElement* dec = make_element("decodebin");
    g_object_set(src, "location", o.location.c_str(), "loop", o.loop, nullptr);
    gst_bin_add_many(GST_BIN(pipe_), src, dec, nullptr);
    gst_element_link(src, dec);
    g_signal_connect(dec, "deep-element-added", G_CALLBACK(on_decoder_element),
                     GINT_TO_POINTER(o.skip_bad_frames));
    link_decoded_video(dec, convert);
  } else {
    gchar* uri = gst_uri_is_valid(o.location.c_str())
                     ? g_strdup(o.location.c_str())
                     : gst_filename_to_uri(o.location.c_str(), nullptr);
    if (!uri) {
      teardown();
      throw std::invalid_argument("location '" + o.location + "' is not a file or URI");
    }
    GstElement* dec = make_element("uridecodebin");
    g_object_set(dec, "uri", uri, nullptr);
    g_signal_connect(dec, "deep-element-added", G_CALLBACK(on_decoder_element),
                     GINT_TO_POINTER(o.skip_bad_frames));
    g_free(uri);
    gst_bin_add(GST_BIN(pipe_), dec);
    link_decoded_video(dec, convert);
  }
  const std::string input = o.v4l2 ? "device " + o.device : o.location;
  // Errors surface here, when the element starts (a missing file, a busy
  // device, an undecodable stream), not later as a missing frame.
  if (gst_element_set_state(pipe_, GST_STATE_PLAYING) == GST_STATE_CHANGE_FAILURE ||
      gst_element_get_state(pipe_, nullptr, nullptr, 10 * GST_SECOND) == GST_STATE_CHANGE_FAILURE) {
    // The failure can be seen before its error message is posted (it comes
    // from the decoder's thread): wait for the reason a little.
    const std::string why = error(GST_SECOND);
    teardown();
    throw std::runtime_error("cannot open " + input + (why.empty() ? "" : ": " + why));
  }
  if (const std::string why = error(); !why.empty()) {
    teardown();
    throw std::runtime_error("cannot decode " + input + ": " + why);
  }
}

DecodedInput::~DecodedInput() {
  teardown();
}

void DecodedInput::teardown() {
  if (pipe_) {
    gst_element_set_state(pipe_, GST_STATE_NULL);
    gst_object_unref(sink_);
    gst_object_unref(pipe_);
    pipe_ = sink_ = nullptr;
  }
}

std::string DecodedInput::error(GstClockTime wait) {
  GstBus* bus = gst_element_get_bus(pipe_);
  GstMessage* m = gst_bus_timed_pop_filtered(bus, wait, GST_MESSAGE_ERROR);
  gst_object_unref(bus);
  if (!m) return "";
  GError* e = nullptr;
  gchar* dbg = nullptr;
  gst_message_parse_error(m, &e, &dbg);
  std::string what = std::string(e->message) + " (" + (dbg ? dbg : "") + ")";
  g_clear_error(&e);
  g_free(dbg);
  gst_message_unref(m);
  return what;
}

GstSample* DecodedInput::pull(GstClockTime timeout, std::string* why) {
  GstAppSink* sink = GST_APP_SINK(sink_);
  for (GstClockTime waited = 0; waited < timeout; waited += 50 * GST_MSECOND) {
    if (GstSample* s = gst_app_sink_try_pull_sample(sink, 50 * GST_MSECOND)) return s;
    if (gst_app_sink_is_eos(sink)) return nullptr;
    if (std::string e = error(); !e.empty()) {
      *why = std::move(e);
      return nullptr;
    }
  }
  return nullptr;
}

GstSample* DecodedInput::newest() {
  GstSample* s = nullptr;
  while (GstSample* n = gst_app_sink_try_pull_sample(GST_APP_SINK(sink_), 0)) {
    if (s) gst_sample_unref(s);
    s = n;
  }
  return s;
}

bool DecodedInput::at_end() const {
  return gst_app_sink_is_eos(GST_APP_SINK(sink_));
}

bool DecodedInput::rewind() {
  return gst_element_seek_simple(pipe_, GST_FORMAT_TIME, GST_SEEK_FLAG_FLUSH, 0);
}

DecodedInput::Next DecodedInput::next(bool have_one) {
  Next n;
  if (o_.v4l2) {
    n.sample = newest();
    if (!n.sample && !have_one) n.sample = pull(5 * GST_SECOND, &n.error);
    return n;
  }
  n.sample = pull(30 * GST_SECOND, &n.error);
  if (!n.sample && n.error.empty() && at_end() && o_.loop && rewind())
    n.sample = pull(30 * GST_SECOND, &n.error);
  n.end = !n.sample && at_end();
  n.skipped = take_skipped();
  return n;
}

std::vector<std::string> DecodedInput::take_skipped() {
  std::lock_guard<std::mutex> l(lock_);
  return std::exchange(skipped_, {});
}

}  // namespace lfgst
