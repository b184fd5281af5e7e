// A focal surface estimated from the cameras' fragments (issue 16: "real
// time, and distributed"). FocalSurfaceEstimator (lf/focus/focal_surface.h) needs
// every camera's image in one process; in the distributed system no image
// leaves its camera host, so the sweep is asked of the cameras instead, as
// ordinary view requests: a surface probe is the view at low resolution
// (SurfaceOptions::analysis_width pixels wide, the same eye, orientation
// and field of view), once per candidate plane parallel to the camera plane
// (SurfaceOptions::planes planes evenly spaced in inverse depth over a
// parallax of 0 .. max_parallax_px between neighbouring cameras, as the
// estimator's first pass). Each camera answers with its fragment of each
// step: only the pixels its aperture weight covers, warped through that
// plane. Where the plane passes through the scene the contributing cameras
// agree; whoever receives all fragments (the compositor) measures their
// aperture-weighted grey-level variance per pixel (photo-consistency, as
// lf::photo_consistency does from whole images), sums it per tile of the
// output and labels the tiles exactly as the estimator does
// (surface_from_costs: semi-global matching, the single plane where a tile
// has no texture). One pass at the probe's resolution: the estimator's
// finer second pass would need a second round trip.
//
// Cost per probe (64 Chess cameras, 640x480 output): planes x (160 x 120)
// output pixels, each covered by about 3 cameras' fragments: about 1.8 M
// fragment pixels, twice a 640x480 frame's; amortised over the requests
// between two probes (lfviewrequest `surface-interval`).
//
// Protocol: probe requests carry the viewer's id and a sequence with bits
// 48..63 = 0x4001 (kSurfaceProbeBit; focus probes use 0x4000), the probe id
// in bits 16..47 and the step k (plane k) in bits 0..15, so they never
// collide with frame requests (below 2^62) or focus probes. lfviewrequest
// sends a probe's requests in one buffer and each camera answers them in
// one (lf/wire/probe_bundle.h).
#pragma once

#include <cstdint>
#include <vector>

#include "lf/focus/focal_surface.h"
#include "lf/focus/probe_answers.h"
#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"
#include "lf/render/fragment.h"

namespace lf {

constexpr uint64_t kSurfaceProbeBit = (uint64_t{1} << 62) | (uint64_t{1} << 48);

// Exactly the pattern: bits 48..63 = 0x4001 and a step below
// FocalSurface::kMaxPlanes (the most planes a probe can have).
inline bool is_surface_probe(uint64_t sequence) {
  return (sequence >> 48) == (kSurfaceProbeBit >> 48) &&
         (sequence & 0xffff) < static_cast<uint64_t>(FocalSurface::kMaxPlanes);
}
inline uint64_t surface_probe_sequence(uint32_t probe_id, int step) {
  return kSurfaceProbeBit | (uint64_t{probe_id} << 16) | static_cast<uint16_t>(step);
}
inline uint32_t surface_probe_id(uint64_t sequence) {
  return static_cast<uint32_t>((sequence >> 16) & 0xffffffffu);
}
inline int surface_probe_step(uint64_t sequence) {
  return static_cast<int>(sequence & 0xffff);
}

// The opt.planes requests of a probe of `view` (its surface and focal
// plane ignored): step k is the view scaled to min(opt.analysis_width,
// width) pixels wide (lf::scaled_request), focused on the plane at inverse
// depth FocalSurfaceEstimator's candidate_q(k) (rig units^-1), with
// sequence surface_probe_sequence(probe_id, k). Throws
// std::invalid_argument on bad options (as FocalSurfaceEstimator).
std::vector<ViewRequest> surface_probe_requests(const Rig& rig, const ViewRequest& view,
                                                uint32_t probe_id, const SurfaceOptions& opt = {});

// The fragments of one surface probe as they come, scored once complete or
// at a deadline from the complete cameras only (lf/focus/probe_answers.h).
// Bounded: one fragment per (camera, step); fragments for another size than
// the probe's are refused, and so are fragments beyond kMaxOverlap times the
// probe's pixels in all (the tent aperture blends at most 3 cameras at a
// pixel, so honest answers stay below 3x; a peer's cannot make it keep
// more); the caller admits only the rig's cameras.
class SurfaceProbeAnswers : public ProbeFragments {
 public:
  static constexpr size_t kMaxOverlap = 4;
  // For an output of width x height pixels (the probe's size follows).
  SurfaceProbeAnswers(int width, int height, SurfaceOptions opt = {});
  // Keeps fragment `f` of step `step` of camera f.camera_id (premultiplied
  // RGBA or BGRA, alpha = aperture weight); false (ignored) for a repeated
  // (camera, step), a step out of range, a fragment for another size or
  // one over the pixel budget.
  bool add(int step, Fragment f);
  int width() const { return width_; }  // the output's
  int height() const { return height_; }
  int probe_width() const { return aw_; }
  int probe_height() const { return ah_; }
  // The surface (tiles of opt.tile over the output) from the complete
  // cameras; `ok` false (and a single plane at infinity) when fewer than 3
  // planes were answered by them or no pixel was seen by most of the
  // aperture (every camera sat the probe out with an empty fragment). With
  // `prior` (the last estimate of this viewer's view), hysteresis
  // (SurfaceOptions::change_penalty). The probe's steps are gathered on
  // every core (cv::parallel_for_), or with `every_core` false on the
  // calling thread only: OpenCV runs one parallel loop at a time in a
  // process, so an estimate beside a compositor (lf::ProbeScoring's
  // background thread) would leave the compositor's loops one thread. The
  // estimate is the same either way, value for value.
  SurfaceEstimate estimate(const Rig& rig, bool* ok = nullptr, const SurfacePrior* prior = nullptr,
                           bool every_core = true) const;
  // The fragment pixels kept: 0 when every answer was an empty fragment
  // (every camera sat the probe out: its instant was not among its frames).
  size_t pixels() const { return pixels_; }

 private:
  int width_, height_, aw_, ah_;
  SurfaceOptions opt_;
  size_t pixels_ = 0;
};

}  // namespace lf
