// The viewer of Yang et al. 2002 (Section 4: a virtual camera that sends a
// view request each tick of the request rate) as one session: its view
// settings and the views they build, the navigation gestures, and the
// assembly of a tick's requests with the focus and surface probes that go
// with them (lib/lf/session/viewer.h has the schedules it drives).
//
// Plain C++, no GStreamer: lfviewrequest is the glue (properties, events,
// the clock, buffers). Not thread-safe: the element locks. Positions are in
// the rig's units and world frame (lib/lf/geometry/rig.h); pointer
// positions are output pixels (x right, y down, origin at the top-left
// pixel's centre); ticks are request sequence numbers; times microseconds of
// a monotonic clock. Throws std::invalid_argument where a setting is bad.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"
#include "lf/geometry/view_builder.h"
#include "lf/session/viewer.h"

namespace lf {

// The view settings of a viewer (lfviewrequest's view properties, which
// document each; docs/elements.md). Lengths in rig units, angles in degrees.
struct ViewerSettings {
  int width = 640, height = 480;           // output pixels (a quilt's whole frame)
  std::vector<double> position, look_at;   // 3 numbers each, or empty (unset)
  double eye_s = 0, eye_t = 0, eye_w = 0;  // eye offset on the camera plane
  double vfov = 0;                         // 0: from the cameras
  std::string focal_plane = "infinity";    // lf/io/parse.h parse_focal_plane
  double focal_depth = 0;                  // > 0: wins over focal_plane
  double aperture = 0, f_number = 0;       // rig units; full-frame-equivalent
  unsigned ulr_cameras = 0;                // 0: the tent (aperture, f-number); else ULR's k
  bool four_camera = false;  // Aperture::kFourCamera where no ULR, aperture or f-number is set
  Sampling sampling = Sampling::kBilinear;
  std::string path;  // keyframed camera path (JSON)
  double orbit = 0, dolly = 0;
  int path_frames = 120;
  double stereo_baseline = 0;  // > 0: a left and a right request per tick
  bool continuous_focus = false;
  bool focal_surface = true;
  unsigned surface_interval = 60;  // ticks from one surface probe to the next
  // A quilt (lib/lf/render/quilt.h): 0 views for one view; width x height
  // is then the quilt frame, of quilt_cols x quilt_rows tiles.
  unsigned quilt_views = 0, quilt_cols = 8, quilt_rows = 6;
  double view_cone = 0, quilt_baseline = 0;  // degrees; rig units (0 and 0: the array's width)
};

// A click whose probe has no answer this long after it (at least this many
// ticks) is probed again (lf::FocusSchedule).
constexpr int64_t kClickRetryAfterUs = 1'000'000;
constexpr uint64_t kClickRetryTicks = 5;

// The views and the focal plane that view settings describe.
struct ViewerViews {
  ViewerSettings s;  // the settings they were built from
  ViewSequence sequence;
  FocalPlane plane;
};
// Builds them; throws std::invalid_argument when the settings are bad (a
// position without 3 finite numbers, a quilt that does not tile the frame or
// with a stereo baseline, a bad focal plane or path).
std::shared_ptr<const ViewerViews> build_viewer_views(const ViewerSettings& s, const Rig& rig);

// A pointer or key gesture from the video sink (GStreamer's navigation
// events, in the element's words).
struct Gesture {
  enum class Kind { kPress, kRelease, kMove, kScroll, kKey } kind = Kind::kMove;
  int button = 0;        // press, release: 1 left, 3 right, 4/5 an X wheel notch
  bool control = false;  // press: Control held
  double x = 0, y = 0;   // output pixels
  double dy = 0;         // scroll: notches, up positive
  std::string key;       // key: GStreamer's key name
};

// Something a tick could not do as asked; the tick went on without it. The
// element turns these into warnings (`limited`: at most one a second).
struct ViewerNotice {
  enum class Kind {
    kBadEyeOffset,    // the eye offset gave an invalid view: the view without it
    kFNumberIgnored,  // f-number set but the rig's unit is not a length
    kSurfaceMisfit,   // the surface answered does not fit the view: dropped
    kNoFocusProbe,    // a focus probe could not be made
    kNoSurfaceProbe,  // a surface probe could not be made
  } kind;
  std::string detail;
  // What it means, for a warning's title; null for kNoFocusProbe and
  // kNoSurfaceProbe (internal: a debug line).
  const char* summary() const;
};

// What goes out for one tick.
struct ViewerTick {
  std::vector<ViewRequest> requests;             // the quilt's one, the stereo pair, or one
  std::vector<std::vector<ViewRequest>> probes;  // each probe's steps (one buffer each)
  std::vector<ViewerNotice> notices;
  std::optional<FocusSchedule::Probe> focus_probe;  // the focus probe sent, if any
  uint32_t surface_probe = 0;                       // the surface probe sent (0: none)
  bool refocused = false;                           // the focus changed: focal-surface goes off
  bool gave_up = false;              // no surface probe was ever answered: probing stops
  uint32_t surface_probes_sent = 0;  // so far
  unsigned surface_planes = 0, two_plane_tiles = 0;  // of the surface the request carries
};

class ViewerSession {
 public:
  ViewerSession(std::shared_ptr<const Rig> rig, unsigned viewer_id,
                std::shared_ptr<const ViewerViews> views);

  const Rig& rig() const { return *rig_; }
  const std::shared_ptr<const ViewerViews>& views() const { return views_; }
  void set_views(std::shared_ptr<const ViewerViews> v) { views_ = std::move(v); }
  FocusSchedule& focus() { return focus_; }
  SurfaceSchedule& surface() { return surface_; }

  // A gesture, with `now` the view settings in use: the eye and focal depth
  // it moves to (the eye kept over the camera array), or none when it
  // changes neither (a click to focus, right button or Control + left, is
  // scheduled as a focus probe). Depths stay within (0, max_depth].
  std::optional<EyeAndFocus> navigate(const Gesture& g, const ViewerSettings& now,
                                      double max_depth);

  // An answer (inverse depth q) to focus probe `probe`: the focal depth to
  // move to, or none (lf::FocusSchedule::answer), with `focal_depth` the
  // setting in use (0: the views' focal plane).
  std::optional<double> focus_answer(uint32_t probe, double q, double focal_depth,
                                     double max_depth);

  // Tick `k` at `now_us`, a request period of `period_us` apart: the centre
  // eye's request from the views (with the eye offset, aperture and
  // sampling), the probes that go with it, the surface in use applied, and
  // the tick's shape (quilt, stereo pair or alone). `now` is the settings
  // as they are (the focus settings are read from it, so that a refocus
  // shows in the very tick); `first_wait_failed`: not live, the first
  // surface probe's wait had no answer.
  ViewerTick tick(uint64_t k, const ViewerSettings& now, int64_t period_us, int64_t now_us,
                  bool first_wait_failed = false);

 private:
  std::shared_ptr<const Rig> rig_;
  unsigned viewer_id_;
  std::shared_ptr<const ViewerViews> views_;
  FocusSchedule focus_;
  SurfaceSchedule surface_;
  bool dragging_ = false;
  double drag_x_ = 0, drag_y_ = 0;
};

}  // namespace lf
