// The fragments of one probe as they come (a focus probe, lf/focus/focus_probe.h,
// or a surface probe, lf/focus/surface_probe.h), kept by camera: the bookkeeping
// that FocusProbeAnswers and SurfaceProbeAnswers share. A probe is scored
// from the "complete" cameras only, those that answered as many steps as
// the most complete one: a camera missing from some steps (late, or gone)
// would change the set of cameras compared from step to step.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "lf/render/fragment.h"

namespace lf {

class ProbeFragments {
 public:
  size_t fragments() const { return count_; }
  // Fragments of a camera that sat the probe out: empty, with no capture
  // time (its instant was not among its frames; gst/lffragment.cpp). A
  // camera that sees none of a step answers empty too, with its frame's
  // time.
  size_t sat_out() const { return sat_out_; }
  // Steps answered by the most complete camera, and the cameras with that
  // many (those scored).
  int steps() const;
  int complete_cameras() const;
  // The newest capture time (ns, Fragment::capture_time_ns) among the
  // complete cameras' fragments; -1 if none is known.
  int64_t capture_time_ns() const;
  // Calls fn(step, fragment) for every fragment of the complete cameras.
  template <class F>
  void for_each_complete(F fn) const {
    const size_t most = static_cast<size_t>(steps());
    for (const auto& [camera, answers] : by_camera_)
      if (answers.size() == most)
        for (const auto& [step, f] : answers) fn(step, f);
  }

 protected:
  // Keeps fragment `f` of step `step` (0 <= step < `steps`) of its camera
  // (f.camera_id); false (ignored) for a repeated (camera, step) or a step
  // out of range.
  bool keep(int step, int steps, Fragment f);

 private:
  std::map<uint32_t, std::vector<std::pair<int, Fragment>>> by_camera_;
  size_t count_ = 0;
  size_t sat_out_ = 0;
};

}  // namespace lf
