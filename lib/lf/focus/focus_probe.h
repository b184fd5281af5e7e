// Click to focus from the fragments themselves (issue 14). A focus probe asks
// the cameras, through ordinary view requests, for a small window of the
// view around the clicked pixel, once per candidate plane parallel to the
// camera plane (a plane sweep). Each camera answers with its fragment, as for
// any request: only the pixels its aperture weight covers, already warped
// through the candidate plane. Where the plane passes through the scene at
// that pixel the contributing cameras agree; the compositor measures the
// aperture-weighted colour variance among the cameras' fragments
// (photo-consistency, as lf::AutofocusContext does from whole images) and
// runs the focal surface estimator on the window (lf/focus/focal_surface.h
// surface_from_costs: kFocusProbeTile-pixel tiles, costs aggregated over
// 3 x 3 tiles, semi-global matching, textureless tiles keeping the window's
// best single plane); the answer is the plane of the clicked pixel's tile,
// refined by a parabola. So what is under the cursor wins even where it
// fills a small part of the window (a thin object before a background,
// whose mean over the window would pick the background). No camera image
// leaves its host, and nothing but the wire format's requests and fragments
// is needed, so it works the same over RTP.
//
// Protocol: probe requests carry the viewer's id and a sequence number with
// bits 48..63 = 0x4000 (kFocusProbeBit), the probe id in bits 16..47 and the
// step k in bits 0..15 (so they never collide with lfviewrequest's frame
// requests, whose sequences stay below 2^62). The compositor collects a few
// probes at once (FocusProbeAnswers each; on a busy machine the next probe
// starts before the last is complete) and answers only the viewer it
// composites; lfviewrequest applies only answers to the probes it sent, so
// forged probe fragments can at worst delay a focus by the probe deadline
// (1 s, or the compositor's latency when longer). Steps k = 0 .. kFocusProbeSteps-1 sweep inverse
// depth q_k = q_max * k / (steps - 1) with q_max giving kFocusProbeMaxParallaxPx of parallax
// between neighbouring cameras (0: the plane at infinity). The window is (2 * kFocusProbeRadius +
// 1) pixels square, centred on the pixel.
#pragma once

#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include "lf/focus/probe_answers.h"
#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"
#include "lf/render/fragment.h"

namespace lf {

constexpr uint64_t kFocusProbeBit = uint64_t{1} << 62;
constexpr int kFocusProbeSteps = 32;
constexpr int kFocusProbeRadius = 16;  // output pixels: a 33 x 33 window
constexpr int kFocusProbeSide = 2 * kFocusProbeRadius + 1;
constexpr int kFocusProbeTile = 4;  // estimator tiles over the window: 9 x 9 (the last 1 px)
constexpr double kFocusProbeMaxParallaxPx = 24.0;

// Exactly the probe pattern: bits 48..63 = 0x4000 and a step below
// kFocusProbeSteps (so a hostile or restarted viewer's huge frame sequence,
// e.g. 2^63 - 1, is still a frame request).
inline bool is_focus_probe(uint64_t sequence) {
  return (sequence >> 48) == (kFocusProbeBit >> 48) && (sequence & 0xffff) < kFocusProbeSteps;
}
inline uint64_t focus_probe_sequence(uint32_t probe_id, int step) {
  return kFocusProbeBit | (uint64_t{probe_id} << 16) | static_cast<uint16_t>(step);
}
inline uint32_t focus_probe_id(uint64_t sequence) {
  return static_cast<uint32_t>((sequence >> 16) & 0xffffffffu);
}
inline int focus_probe_step(uint64_t sequence) {
  return static_cast<int>(sequence & 0xffff);
}

// Inverse depth (rig units^-1, along the camera plane's normal) of step k.
double focus_probe_inverse_depth(const Rig& rig, int step);

// The kFocusProbeSteps requests of a probe at output pixel (x, y) of `view`.
// Step k's window is centred on the point where the pixel's ray meets
// candidate plane k, seen from the probe's eye: the centre of the aperture
// triangle around where the ray meets the camera plane, on the camera plane
// (so all three of its cameras blend with equal weight; an eye at a camera
// would see through that camera alone). Same orientation and focal length
// as the view. Sequences from focus_probe_sequence. Steps whose point lies
// behind the probe's eye are left out.
std::vector<ViewRequest> focus_probe_requests(const Rig& rig, const ViewRequest& view, double x,
                                              double y, uint32_t probe_id);

// Accumulates the fragments of one probe and scores its planes.
class FocusProbeScore {
 public:
  FocusProbeScore();
  // A fragment of step `step` (premultiplied RGBA, alpha = aperture weight).
  // Fragments of another size than the window are ignored.
  void add(int step, const Fragment& f);
  // Mean over window pixels seen by at least two cameras of the weighted
  // colour standard deviation among the cameras (8-bit levels, truncated at
  // 25 for occlusions), per step; -1 where no pixel had two cameras.
  std::vector<double> costs() const;
  // The inverse depth at the clicked pixel (the window's centre) by the
  // focal surface estimator on the window (see the top of this file);
  // false when fewer than half the steps could be scored.
  bool best(const Rig& rig, double* inverse_depth) const;

 private:
  static constexpr int kSide = kFocusProbeSide;
  // The cameras' weighted colour variance at window pixel p of a step,
  // per channel (levels^2), or -1 where fewer than two cameras saw it.
  double variance(int step, int p) const;
  // Per step and window pixel: sum w, sum w c (3), sum w c^2 (3), cameras.
  std::vector<double> sums_;
  std::vector<int> cameras_;
};

// The fragments of one focus probe as they come, scored once complete or
// at a deadline from the complete cameras only (lf/focus/probe_answers.h: on a
// loaded machine a probe scored from 164 of its 288 fragments answered 1.46
// for a surface at 0.80). Bounded: fragments beyond kFocusProbeSteps per
// camera, repeats and bad steps are refused.
class FocusProbeAnswers : public ProbeFragments {
 public:
  // Keeps fragment `f` of step `step` of its camera (f.camera_id); false
  // (ignored) for a repeated (camera, step) or a step out of range.
  bool add(int step, Fragment f) { return keep(step, kFocusProbeSteps, std::move(f)); }
  // FocusProbeScore::best over the complete cameras.
  bool best(const Rig& rig, double* inverse_depth) const;
};

}  // namespace lf
