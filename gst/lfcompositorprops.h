// lfcompositor's interface as gst-inspect-1.0 shows it: its documentation,
// metadata and properties, each property declared once with its GParamSpec
// over CompositorSettings.
#pragma once

#include <gst/gst.h>

#include <string>

#include "lf/render/renderer.h"
#include "lfprops.h"
#include "lfrate.h"

namespace lfgst {

// Largest output frame side (its accumulators take 16 bytes a pixel).
constexpr int kMaxOutputSide = 8192;

struct CompositorSettings {
  std::string rig;
  gint viewer_id = 0;
  gint width = 0, height = 0;  // 0: from the fragment caps
  Fraction framerate{0, 1};    // 0/1: from the fragment caps
  bool stereo = false;
  bool second_planes = true;  // surface probes: second planes at depth edges and thin structures
  lf::Backend backend = lf::Backend::kAuto;
  gdouble max_pixel_rate = kDefaultMaxPixelRate;  // live: output pixels a second composited
  bool adaptive_deadline = true;  // live: the deadline from the fragments' arrival times
  // Read-only statistics, written by the aggregate thread under the lock.
  guint64 frames = 0;       // frames composited since start
  guint last_cameras = 0;   // cameras (per eye) whose fragment was in the last frame
  guint64 over_budget = 0;  // requests dropped above max-pixel-rate
};

// lfcompositor's metadata (long name, class, description, example, events).
void describe_compositor(GstElementClass* ec);
// Installs its properties on `oc`, bound in `props`.
void install_compositor_properties(GObjectClass* oc, Properties<CompositorSettings>* props);

}  // namespace lfgst
