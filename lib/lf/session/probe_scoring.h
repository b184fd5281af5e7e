// The compositor host's probe scoring: the fragments of focus probes
// (lib/lf/focus/focus_probe.h: the depth under a clicked pixel) and of
// surface probes (lib/lf/focus/surface_probe.h: a focal surface for the
// whole view) are collected per probe and scored, never composited. A probe
// is scored when every camera of the rig has answered every step, when a
// newer one needs its place (ProbeCollector), or at a deadline with the
// cameras that answered every step they sent (a dead camera). A viewer's
// surfaces are steady in time: each estimate has the viewer's last one as
// its prior (hysteresis, lib/lf/focus/focal_surface.h SurfacePrior). This is the
// one place where every camera's contribution arrives separately, so the
// estimate works the same when the cameras are on other hosts.
//
// Plain C++, no GStreamer: lfcompositor is the glue (it turns outcomes into
// lf-focus and lf-surface events, or warnings). Times are microseconds of a
// monotonic clock. Not thread-safe (its background estimates touch nothing
// of it but their own probe).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <future>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lf/focus/focal_surface.h"
#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/geometry/rig.h"
#include "lf/session/frame_assembly.h"

namespace lf {

// What scoring one probe gave.
struct ProbeOutcome {
  enum class Kind { kFocus, kSurface } kind = Kind::kFocus;
  enum class Result {
    kAnswer,      // `inverse_depth` (focus) or `surface` (surface) hold the answer
    kSatOut,      // a surface probe every camera sat out (its instant was not among
                  // their frames), the first in a row: worth a log line, not a warning
    kIncomplete,  // a surface probe scored before every camera answered every
                  // step (a newer probe needed its place, or its deadline passed:
                  // a busy host), or that some cameras sat out (a live host
                  // starting), whose estimate failed, the first in a row:
                  // worth a log line, not a warning
    kFailed,      // nothing could be measured: `why` says what was wrong
  } result = Result::kFailed;
  uint32_t viewer = 0, probe = 0;
  int64_t capture_time_ns = -1;  // newest capture time of the frames measured (-1: unknown)
  size_t fragments = 0;          // fragments collected
  size_t sat_out = 0;            // of them, empty ones of cameras that sat the probe out
  int cameras = 0;               // cameras that answered every step
  std::string why;               // kFailed: the reason
  // kFocus, kAnswer: inverse depth under the clicked pixel (rig units^-1).
  double inverse_depth = 0;
  // kSurface, kAnswer: never empty (one plane everywhere when the scene needs
  // one); planes_used distinct planes; `textured` of `tiles` decided by the images.
  FocalSurface surface;
  int planes_used = 0;
  size_t textured = 0, tiles = 0;
  double estimate_ms = 0;  // time spent estimating the surface
  // A line saying what came of the probe (for a log, or a warning's detail).
  std::string describe() const;
  // kFailed: a warning's title ("Cannot focus at the clicked point", ...).
  const char* summary() const;
};

class ProbeScoring {
 public:
  // Probes open at once: focus (continuous focus probes every 5 requests,
  // so the next starts before the last is complete on a busy machine) and
  // surface (one every `surface-interval` requests).
  static constexpr size_t kMaxFocusProbes = 4;
  static constexpr size_t kMaxSurfaceProbes = 2;

  // `rig` (may be null: probes then wait for their deadline, and fail for
  // lack of geometry).
  explicit ProbeScoring(std::shared_ptr<const Rig> rig) : rig_(std::move(rig)) {}
  // Waits for the estimates still running (at most kMaxSurfaceProbes).
  ~ProbeScoring();
  ProbeScoring(const ProbeScoring&) = delete;
  ProbeScoring& operator=(const ProbeScoring&) = delete;
  // Where a surface probe's estimate runs (tens of ms at 1080p): false (the
  // default), at once, in the absorb() or expire() that scored the probe;
  // true, on a thread of its own (std::async), so that the caller's frames
  // go on meanwhile (lfcompositor: a live 1080p stream kept its rate), its
  // outcome returned by the first take() after it is done (in the order
  // the probes were scored). Its prior is the viewer's last surface
  // concluded before it started.
  void set_background(bool background) { background_ = background; }
  // Waits for the estimates still running; take() then returns them.
  void wait();

  // One camera's answer to a probe (its viewer and camera already checked):
  // one step's fragment, or a bundle of its steps (lib/lf/wire/probe_bundle.h),
  // for an output of width x height. Surface probes opened now use `surface`.
  // A probe complete with it is scored (see take()). Throws lf::WireError
  // on a malformed answer (the steps read before the bad one are kept), and
  // std::invalid_argument for an output size no probe can have. A bundle that mixes probes, viewers
  // or cameras is refused whole.
  void absorb(const uint8_t* data, size_t size, int width, int height,
              const SurfaceOptions& surface, int64_t now_us);
  // Scores the probes started more than `deadline_us` before `now_us`.
  void expire(int64_t now_us, int64_t deadline_us);
  // The outcomes since the last call, in the order scored.
  std::vector<ProbeOutcome> take();
  size_t open() const { return focus_.size() + surface_.size(); }

 private:
  using FocusProbes = ProbeCollector<FocusProbeAnswers>;
  using SurfaceProbes = ProbeCollector<SurfaceProbeAnswers>;
  void absorb_focus(const uint8_t* data, size_t size, uint64_t sequence, int64_t now_us);
  void absorb_surface(const uint8_t* data, size_t size, uint64_t sequence, uint32_t viewer,
                      int width, int height, const SurfaceOptions& opt, int64_t now_us);
  void finish_focus(FocusProbes::Iter it);
  void finish_surface(SurfaceProbes::Iter it);
  // A surface estimate: pure (any thread), then concluded here (the
  // outcome, the viewer's prior).
  struct Estimated {
    SurfaceEstimate e;
    bool ok = false, threw = false;
    std::string why;  // threw: the exception's message
    double ms = 0;
  };
  // `every_core`: SurfaceProbeAnswers::estimate's (false on the background
  // thread).
  Estimated estimate_surface(const SurfaceProbes::Probe& probe, const SurfacePrior* prior,
                             bool every_core = true) const;
  void conclude_surface(const SurfaceProbes::Probe& probe, Estimated est);
  // Concludes the estimates done, in order (block: all of them, waiting).
  void collect(bool block);
  struct Running {
    std::shared_ptr<SurfaceProbes::Probe> probe;
    std::future<Estimated> estimated;
  };
  bool background_ = false;
  std::deque<Running> running_;

  std::shared_ptr<const Rig> rig_;
  // Each viewer's last surface: the next estimate's prior (hysteresis,
  // SurfaceOptions::change_penalty); at most kMaxPriors viewers.
  static constexpr size_t kMaxPriors = 16;
  std::map<uint32_t, SurfacePrior> priors_;
  FocusProbes focus_{kMaxFocusProbes};
  SurfaceProbes surface_{kMaxSurfaceProbes};
  // Surface probes in a row that measured nothing (kSatOut, kIncomplete).
  unsigned unmeasured_in_a_row_ = 0;
  std::vector<ProbeOutcome> outcomes_;
};

}  // namespace lf
