// The collection's custom events, one codec each (a typed struct <->
// GstStructure), used by the elements, lf-web, the tests and the C and
// Python examples (through lfviewrequest's view-event action;
// docs/steering.md). Every structure carries
// `version` (uint, kEventVersion); a reader takes a structure without one
// (written before the field) as version 1 and refuses a newer one, naming
// it. Readers check every field a peer or an application may get wrong
// and say what was wrong; nothing they read allocates more than the
// bounds below.
//
//  * lf-view (upstream: an application, lf-web or a video sink's window ->
//    lfviewrequest): lfviewrequest properties that may change while
//    playing, set at once and whole; optional viewer-id (uint) addresses
//    one viewer.
//  * lf-focus (upstream: lfcompositor -> lfviewrequest): the answer to a
//    focus probe (lib/lf/focus/focus_probe.h).
//  * lf-surface (upstream: lfcompositor -> lfviewrequest): the answer to a
//    surface probe (lib/lf/focus/surface_probe.h), the focal surface the
//    next requests carry.
//  * lf-rate (an element message on the bus, from lfcompositor, once a
//    second while frames go out): the rate achieved against the rate asked.
#pragma once

#include <gst/gst.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lf/geometry/view.h"
#include "lf/session/compositor_host.h"
#include "lf/session/probe_scoring.h"
#include "lf/session/viewer_session.h"

namespace lfgst {

constexpr guint kEventVersion = 1;

// lf-focus: viewer-id (uint), probe-id (uint), inverse-depth (double >= 0,
// finite; rig units^-1), capture-time (int64: ns of running time of the
// frames measured, -1 unknown).
struct FocusAnswer {
  guint viewer = 0, probe = 0;
  double inverse_depth = 0;
  gint64 capture_ns = -1;
};
GstStructure* focus_structure(const FocusAnswer& a);
bool read_focus(const GstStructure* s, FocusAnswer* a, std::string* why);

// lf-surface: viewer-id (uint), probe-id (uint), capture-time (int64, as
// lf-focus), tile, cols, rows (int: the lf::FocalSurface grid), planes
// (GBytes: 4 doubles per plane, n.x, n.y, n.z, d, world frame, n.X + d =
// 0; plane 0 the single plane), plane-of (GBytes: one plane index per
// tile, row-major), planes-used (int), and with second planes second-of
// (GBytes: one plane index per tile, 255 for none;
// lf::FocalSurface::second_of).
struct SurfaceAnswer {
  guint viewer = 0, probe = 0;
  gint64 capture_ns = -1;
  lf::FocalSurface surface;
  int planes_used = 0;
};
GstStructure* surface_structure(const SurfaceAnswer& a);
// Bounds: tile 4..1024, cols and rows 1..16384, 1..64 planes, one plane
// index per tile, and per tile a second-plane index when second-of is
// there. Only sizes are checked: whoever uses the surface checks it
// against its view (lf::validate).
bool read_surface(const GstStructure* s, SurfaceAnswer* a, std::string* why);

// lf-view: the values to set on `target` (an lfviewrequest), each field a
// property that may change while playing (GST_PARAM_MUTABLE_PLAYING),
// converted to the property's type and within its range (no clamping:
// out of range is refused); 3-number arrays (points) finite and within
// +-max_coord. False, with the first bad field named, when any is bad:
// then nothing is to be set. The values are the caller's to unset.
bool read_view_change(const GstStructure* s, GObject* target, double max_coord,
                      std::vector<std::pair<GParamSpec*, GValue>>* values, std::string* why);
// An lf-view structure of numeric fields (name, value), for viewer
// `viewer` (< 0: every viewer that gets it).
GstStructure* view_change_structure(const std::vector<std::pair<std::string, double>>& fields,
                                    gint64 viewer = -1);
// The lf-view event (upstream custom, transfer full) for `fields`, a
// structure of any name whose fields are `target`'s view properties (any
// type that converts to the property's, points as 3-number arrays) and
// optionally viewer-id: checked by read_view_change, then written by this
// codec (version, the values in the properties' types). Null, with `why`,
// when a field is bad. lfviewrequest's `view-event` action signal, which
// the C and Python examples use.
GstEvent* view_event(const GstStructure* fields, GObject* target, double max_coord,
                     std::string* why);

// The viewer an event addresses: its viewer-id field (uint, or an int >= 0,
// as gst-launch and JSON write it), or none (every viewer).
std::optional<guint> addressed_viewer(const GstStructure* s);

// `event` (transfer full) addressed to `viewer` (>= 0) unless it names one
// already: an adding element tags the navigation and lf-view events from
// its video sink so that only its viewer is steered. Returns it (transfer full).
GstEvent* address_to_viewer(GstEvent* event, gint viewer);

// A navigation event (GstNavigation: a video sink's pointer and keys) as a
// viewer's gesture (lib/lf/session/viewer_session.h); false for one that a
// viewer does not use.
bool read_gesture(GstEvent* event, lf::Gesture* g);

// The lf-focus or lf-surface structure answering a probe (an outcome
// lf::ProbeScoring gave with result kAnswer).
GstStructure* answer_structure(lf::ProbeOutcome&& o);

// lf-rate: viewer-id (int64, -1: not chosen yet), requested-fps (double: the
// viewer's request rate), fps (double: frames composited a second over the
// window), complete-fps (double: of them complete, every camera in by the
// deadline), interval (double, s: the window), over-budget (uint64:
// requests dropped over max-pixel-rate since the start), stale (uint64:
// requests dropped since the start because a newer one was complete first:
// the compositor could not keep the rate, and the newest request wins).
GstStructure* rate_structure(gint64 viewer, double requested_fps, const lf::OutputRate::Report& r,
                             guint64 over_budget, guint64 stale = 0);
// Posts it on `el`'s bus as an element message.
void post_rate(GstElement* el, gint64 viewer, double requested_fps, const lf::OutputRate::Report& r,
               guint64 over_budget, guint64 stale = 0);

// Whether a structure's version is one this codec reads (else `why`).
bool version_ok(const GstStructure* s, std::string* why);

}  // namespace lfgst
