// lffragment's interface as gst-inspect-1.0 shows it: its documentation,
// metadata and properties, each property declared once with its GParamSpec
// over FragmentSettings.
#pragma once

#include <gst/gst.h>

#include <string>

#include "lfbackend.h"
#include "lfprops.h"
#include "lfrate.h"
#include "lfrig.h"

namespace lfgst {

// Which camera frame a request is rendered from (frame-select).
enum class FrameSelect { kNewest = 0, kCaptureTime = 1 };

struct FragmentSettings : CameraAddress {
  std::string rig;
  FragmentEncoding encoding = FragmentEncoding::kRaw;
  gint quality = 90;  // mutable in PLAYING: read live
  guint64 max_pixels = G_GUINT64_CONSTANT(3840) * 2160;
  gdouble max_rate = 240.0;
  gdouble max_pixel_rate = kDefaultMaxPixelRate;
  guint64 frame_timeout = GST_SECOND;
  FrameSelect frame_select = FrameSelect::kNewest;
  lf::Backend backend = lf::Backend::kAuto;
  bool defer = false;         // leave the drawing to an lfcompositor in this process
  bool answer_empty = false;  // a request it cannot answer: an empty fragment (defer: always)
};

// lffragment's metadata (long name, class, description, example, events).
void describe_fragment(GstElementClass* ec);
// Installs its properties on `oc`, bound in `props`.
void install_fragment_properties(GObjectClass* oc, Properties<FragmentSettings>* props);

}  // namespace lfgst
