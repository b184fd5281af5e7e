// lf-gst-bench's several-viewers run (tools/lf-gst-bench.cpp --viewers).
#include "bench/viewers.h"

#include <gst/app/gstappsink.h>

#include <sstream>
#include <stdexcept>
#include <vector>

namespace lfbench {

// V viewers sharing the cameras (lfcamerahost: one fragment stream, routed
// by lffragmentdemux to each viewer's lfcompositor, or with `tee` to every
// one), non-live: viewer v's requests orbit with a phase of its own.
std::string viewers_pipeline(const std::string& rig, int W, int H, const std::string& fr,
                             int viewers, int frames, bool tee) {
  std::ostringstream d;
  d << "funnel name=reqs ! lfcamerahost rig=" << rig << " num-buffers=1 " << fr
    << (tee ? " ! tee name=ft" : " ! lffragmentdemux name=ft");
  for (int v = 0; v < viewers; ++v) {
    d << " lfviewrequest viewer-id=" << v << " rig=" << rig << " width=" << W << " height=" << H
      << " orbit=" << 0.3 + 0.05 * v
      << " path-frames=120 focal-plane=param:-0.2 focal-surface=false num-buffers=" << frames
      << " ! reqs.";
    d << " lfcompositor name=c" << v << " viewer-id=" << v << " rig=" << rig
      << " ! appsink name=out" << v << " sync=false async=false max-buffers=4";
    d << " ft." << (tee ? "" : "src_" + std::to_string(v)) << " ! queue max-size-buffers=64 ! c"
      << v << ".sink_0";
  }
  return d.str();
}

// Runs V appsinks out0..out{V-1} to EOS; returns (frames, seconds) of the
// steady part (after each sink's first frame).
std::pair<size_t, double> run_viewers(const std::string& desc, int viewers) {
  GError* err = nullptr;
  GstElement* p = gst_parse_launch(desc.c_str(), &err);
  if (!p || err) {
    const std::string msg = std::string("pipeline: ") + (err ? err->message : "?");
    g_clear_error(&err);
    if (p) gst_object_unref(p);
    throw std::runtime_error(msg);
  }
  std::vector<GstElement*> sinks;
  for (int v = 0; v < viewers; ++v)
    sinks.push_back(gst_bin_get_by_name(GST_BIN(p), ("out" + std::to_string(v)).c_str()));
  gst_element_set_state(p, GST_STATE_PLAYING);
  size_t n = 0;
  double first = -1, last = 0;
  std::string error;
  GstBus* bus = gst_element_get_bus(p);
  for (bool done = false; !done;) {
    done = true;
    bool any = false;
    for (GstElement* s : sinks) {
      if (gst_app_sink_is_eos(GST_APP_SINK(s))) continue;
      done = false;
      // No waiting on one sink while another has frames.
      if (GstSample* sm = gst_app_sink_try_pull_sample(GST_APP_SINK(s), 0)) {
        const double t = g_get_monotonic_time() / 1e6;
        if (first < 0)
          first = t;
        else
          ++n;
        last = t;
        gst_sample_unref(sm);
        any = true;
      }
    }
    if (!any && !done) g_usleep(200);
    if (GstMessage* m = gst_bus_pop_filtered(bus, GST_MESSAGE_ERROR)) {
      GError* e = nullptr;
      gst_message_parse_error(m, &e, nullptr);
      error = e->message;
      g_clear_error(&e);
      gst_message_unref(m);
      done = true;
    }
  }
  gst_element_set_state(p, GST_STATE_NULL);
  gst_object_unref(bus);
  for (GstElement* s : sinks) gst_object_unref(s);
  gst_object_unref(p);
  if (!error.empty()) throw std::runtime_error("pipeline error: " + error);
  return {n, last - first};
}

}  // namespace lfbench
