#include "lfrate.h"

#include "lfwarn.h"

GST_DEBUG_CATEGORY_STATIC(lf_rate_debug);
#define GST_CAT_DEFAULT lf_rate_debug

namespace lfgst {
namespace {

void init_debug() {
  static gsize done = 0;
  if (g_once_init_enter(&done)) {
    GST_DEBUG_CATEGORY_INIT(lf_rate_debug, "lfrate", 0, "light field request limits");
    g_once_init_leave(&done, 1);
  }
}

// lfarray's limits on the requests coming in, for all its cameras at once.
struct RequestLimitProbe {
  GstElement* host = nullptr;  // not owned: the probe dies with its pad
  double rate = 0, pixel_rate = 0;
  bool live = false;
  RequestLimits limits;
  WarnLimiter warned;
};

GstPadProbeReturn limit(GstPad*, GstPadProbeInfo* info, gpointer data) {
  auto* l = static_cast<RequestLimitProbe*>(data);
  const bool list = GST_PAD_PROBE_INFO_TYPE(info) & GST_PAD_PROBE_TYPE_BUFFER_LIST;
  const guint n = list ? gst_buffer_list_length(GST_PAD_PROBE_INFO_BUFFER_LIST(info)) : 1;
  for (guint i = 0; i < n; ++i) {
    GstBuffer* buf = list ? gst_buffer_list_get(GST_PAD_PROBE_INFO_BUFFER_LIST(info), i)
                          : GST_PAD_PROBE_INFO_BUFFER(info);
    guint8 head[88] = {};
    const gsize got = buf ? gst_buffer_extract(buf, 0, head, sizeof head) : 0;
    if (!admit_or_warn(l->host, l->limits, l->warned, request_viewer(head, got), l->rate,
                       l->pixel_rate, request_pixels(head, got), l->live))
      return GST_PAD_PROBE_DROP;
  }
  return GST_PAD_PROBE_OK;
}

}  // namespace

bool admit_or_warn(GstElement* el, RequestLimits& limits, WarnLimiter& warned, guint32 viewer,
                   double rate, double pixel_rate, double pixels, bool live, double max_pixels,
                   WarnLimiter* too_large) {
  init_debug();
  switch (
      limits.admit(viewer, rate, pixel_rate, pixels, live, g_get_monotonic_time(), max_pixels)) {
    case RequestLimits::Verdict::kTooLarge:
      LF_ELEMENT_WARNING_LIMITED(el, too_large ? *too_large : warned, STREAM, DECODE,
                                 ("Dropping a view request larger than max-pixels"),
                                 "viewer %u asks for a view of %.0f pixels, the limit is %.0f",
                                 viewer, pixels, max_pixels);
      return false;
    case RequestLimits::Verdict::kOverRate:
      LF_ELEMENT_WARNING_LIMITED(el, warned, STREAM, DECODE,
                                 ("Dropping view requests above max-rate"),
                                 "viewer %u sends more than %g requests a second", viewer, rate);
      return false;
    case RequestLimits::Verdict::kOverPixelRate:
      LF_ELEMENT_WARNING_LIMITED(el, warned, STREAM, DECODE,
                                 ("Dropping view requests above max-pixel-rate"),
                                 "viewer %u asks for more than %.0f output pixels a second (views "
                                 "of %.0f pixels)",
                                 viewer, pixel_rate, pixels);
      return false;
    default:
      return true;
  }
}

void limit_requests(GstPad* pad, GstElement* host, double rate, double pixel_rate, bool live) {
  auto* l = new RequestLimitProbe;
  l->host = host, l->rate = rate, l->pixel_rate = pixel_rate, l->live = live;
  gst_pad_add_probe(
      pad, static_cast<GstPadProbeType>(GST_PAD_PROBE_TYPE_BUFFER | GST_PAD_PROBE_TYPE_BUFFER_LIST),
      limit, l, [](gpointer d) { delete static_cast<RequestLimitProbe*>(d); });
}

}  // namespace lfgst
