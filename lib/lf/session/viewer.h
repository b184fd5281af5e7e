// The viewer's request scheduling (the virtual camera of Yang et al. 2002,
// Section 4: a view request each tick of the request rate): which focus
// and surface probes go with a tick's request, which of their answers
// apply, and how the mouse and keys move the eye and the focus.
//
// Plain C++, no GStreamer: lfviewrequest is the glue (properties, events,
// the clock, buffers). Not thread-safe: the element locks. Ticks are the
// request sequence numbers; times are microseconds of a monotonic clock;
// positions are output pixels (x right, y down, origin at the top-left
// pixel's centre) and rig units.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"
#include "lf/render/quilt.h"

namespace lf {

// Click to focus and continuous focus (lib/lf/focus/focus_probe.h): a click's
// probe goes with the next tick, and again (at most kClickRetries times)
// when no answer came retry_ticks later, since on a busy machine a camera
// host drops stale requests, probes included; with continuous focus a probe
// every kContinuousEvery ticks at the last clicked point (the view centre
// before any click).
class FocusSchedule {
 public:
  static constexpr uint64_t kContinuousEvery = 5;
  // Each continuous answer moves the focus this fraction of the way (in
  // inverse depth): smoothing.
  static constexpr double kContinuousGain = 0.5;
  static constexpr int kClickRetries = 2;

  struct Probe {
    uint32_t id = 0;
    double x = 0, y = 0;  // the point probed
    bool click = false;   // a click's (or its retry), else continuous
  };
  // A click at (x, y): probed with the next tick.
  void click(double x, double y);
  // The probe to send with tick `k` (of a width x height view), if any.
  std::optional<Probe> probe_for(uint64_t k, uint64_t retry_ticks, bool continuous, int width,
                                 int height);
  // An answer to probe `id` at inverse depth `q` (>= 0): the inverse depth
  // to focus at, or none when it does not apply. Applied: answers to the
  // last click (its probe, a retry, or a continuous probe sent in between,
  // all at the clicked point) as they are, and answers to continuous probes
  // sent since, part of the way from `current_q`; each once, and never
  // after a newer one (on a busy machine answers come after the next
  // continuous probe has gone out: taking only the newest probe's starved
  // focus).
  std::optional<double> answer(uint32_t id, double q, double current_q);
  bool click_waiting() const { return pending_; }

 private:
  bool pending_ = false;    // a click's probe goes with the next tick
  double x_ = -1, y_ = -1;  // the last click (< 0: none: the view centre)
  uint32_t next_ = 1, click_probe_ = 0, continuous_probe_ = 0, applied_ = 0;
  uint32_t click_first_ = 0;  // the last click's first probe (0: none yet)
  bool new_click_ = false;
  uint64_t click_tick_ = 0;
  int retries_ = 0;
};

// The focal surface from the fragments (lib/lf/focus/surface_probe.h): a probe
// every `interval` ticks (the first at once) of the view without its
// surface; the newest answer is the surface the requests carry. A focus
// change while playing (focal-depth or focal-plane: the wheel, a click's
// answer) takes the view off the surface; when no probe is ever answered
// (no lfcompositor downstream), probing stops with one warning: after the
// first probe's wait (not live), or after kGiveUpProbes probes and
// kGiveUpAfterUs (live).
class SurfaceSchedule {
 public:
  static constexpr uint32_t kGiveUpProbes = 3;
  static constexpr int64_t kGiveUpAfterUs = 5'000'000;

  struct Tick {
    uint32_t probe = 0;      // a surface probe to send with this tick (0: none)
    bool refocused = false;  // the focus changed: the surface is off from now on
    bool gave_up = false;    // no answer ever came: probing stops (warn once)
  };
  // Tick `k`: `want` (focal-surface on, not a quilt), the focus settings
  // now, the probe interval (ticks), whether a non-live wait for the first
  // answer went unanswered, and the time.
  Tick tick(uint64_t k, bool want, double focal_depth, const std::string& focal_plane,
            unsigned interval, bool first_wait_failed, int64_t now_us);
  // An answer to probe `id`: taken (true) when it is the newest so far and
  // one this schedule sent.
  bool answer(uint32_t id, FocalSurface surface);
  // The surface in use (empty: none yet, or dropped).
  const FocalSurface& surface() const { return surface_; }
  void drop_surface() { surface_ = {}; }
  // Not live: the probe sent last, if its answer is still awaited and was
  // not waited for yet (marked waited for).
  std::optional<uint32_t> wait_for();
  bool awaiting() const { return sent_ && probe_ > applied_; }
  bool ever_answered() const { return applied_ != 0; }
  uint32_t probes_sent() const { return probe_; }

 private:
  uint32_t next_ = 1, probe_ = 0, applied_ = 0, waited_ = 0;
  bool sent_ = false, given_up_ = false;
  uint64_t tick_ = 0;
  bool focus_known_ = false;
  double last_depth_ = 0;
  std::string last_plane_;
  int64_t first_us_ = 0;  // when the first probe went
  FocalSurface surface_;
};

// What a pointer or key gesture does to the view (lfviewrequest's
// navigation): the eye's offset on the camera plane (s, t, and w along the
// plane's normal; rig units) and the focal depth (0: the focal-plane
// setting).
struct EyeAndFocus {
  cv::Vec3d eye{0, 0, 0};
  double focal_depth = 0;
};
// A key (GStreamer's names: Left, Right, Up, Down, Page_Up/Prior/plus/
// equal/KP_Add, Page_Down/Next/minus/KP_Subtract, r to reset): the eye a
// quarter of `step` (the rig's camera spacing) sideways, or a whole step
// along w. False (unchanged) for any other key.
bool key_moves_eye(const std::string& key, double step, EyeAndFocus* v);
// A drag of (dx, dy) pixels: the eye 1/40 of `step` per pixel, against
// the drag.
void drag_moves_eye(double dx, double dy, double step, EyeAndFocus* v);
// A wheel of `notches` (up positive): the focal plane nearer (up) or
// farther by 0.25 px of parallax between neighbouring cameras per notch:
// `fx` the cameras' focal length (pixels), `current_q` the inverse depth in
// use; the depth stays within (0, max_depth].
void wheel_moves_focus(double notches, double fx, double step, double current_q, double max_depth,
                       EyeAndFocus* v);

// The shape of a tick's requests beyond the centre eye's: a quilt of eyes
// for a light-field display (lib/lf/render/quilt.h; views 0: none) and its
// baseline (rig units; 0: from view_cone, degrees, at the focal plane's
// distance; both 0: the array's extent along the view's x axis), or a
// stereo pair `stereo_baseline` apart (rig units; 0: none).
struct TickShape {
  Quilt quilt;
  double quilt_baseline = 0, view_cone = 0;
  double stereo_baseline = 0;
};
// The view requests of one tick from `req`, the centre eye's (its view the
// size of one eye): the quilt's one request (the view cols x rows eyes
// large, the centre eye's focal plane shared: no surface), else the left
// and right eyes along the view's x axis (viewer ids v and v + 1), else
// `req` alone.
std::vector<ViewRequest> tick_requests(const Rig& rig, ViewRequest req, const TickShape& shape);

}  // namespace lf
