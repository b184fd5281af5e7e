// lfviewrequest's interface as gst-inspect-1.0 shows it: its documentation,
// metadata and properties. The properties: the viewer's settings (lib/lf/session/
// viewer_session.h ViewerSettings) and what the element adds (rig, viewer
// id, rate, liveness, read-only surface figures), each declared once with
// its GParamSpec (units, ranges, frames: what gst-inspect-1.0 and
// docs/elements.md show). The view properties are also the fields of an
// lf-view event (gst/lfevents.h read_view_change reads them by these specs).
#pragma once

#include <gst/gst.h>

#include <string>

#include "lf/session/viewer_session.h"
#include "lfprops.h"

namespace lfgst {

// Largest eye offset or coordinate, rig units.
constexpr double kMaxCoordinate = 1e12;

struct ViewRequestSettings : lf::ViewerSettings {
  std::string rig;
  guint viewer_id = 0;
  Fraction framerate{30, 1};
  bool live = false;
  guint surface_planes = 0;           // read-only: planes of the surface in use (object lock)
  guint surface_two_plane_tiles = 0;  // read-only: its tiles with a second plane
};

// The specs that navigation and focus answers notify.
struct ViewRequestSpecs {
  GParamSpec *eye_s = nullptr, *eye_t = nullptr, *eye_w = nullptr, *focal_depth = nullptr;
};

// lfviewrequest's metadata (long name, class, description, example, events).
void describe_view_request(GstElementClass* ec);

// Installs the properties on lfviewrequest's class `oc`, bound in `props`.
ViewRequestSpecs install_view_request_properties(GObjectClass* oc,
                                                 Properties<ViewRequestSettings>* props);

// Installs lfviewrequest's action signal `view-event`:
//   GstEvent* view-event (GstElement* lfviewrequest, GstStructure* fields)
// the lf-view upstream event (transfer full) for `fields`, a structure of
// any name whose fields are view properties (names, types and ranges as
// the properties; points as 3-number arrays, rig units) and optionally
// viewer-id (uint), written by the events' codec (gst/lfevents.h
// view_event) with its version; null when a field is bad (the log says
// which). The event may be sent at any element downstream of the
// lfviewrequest it is for, e.g. the video sink.
void install_view_request_actions(GObjectClass* oc);

}  // namespace lfgst
