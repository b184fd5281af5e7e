// Probe bundles: all steps of one focus or surface probe in one buffer each
// way. A probe is a plane sweep of 32 steps (lf/focus/focus_probe.h,
// lf/focus/surface_probe.h); sent as 32 requests, every camera answered 32 times,
// so a probe of 64 cameras was 2048 fragment buffers through queues,
// threads and the compositor, for about two frames' worth of pixels. As a
// bundle it is one request buffer and one answer buffer per camera.
//
// Requests: the steps' requests back to back, each a whole version-2 request
// (kRequestSize bytes with its own CRC, lf/wire/wire.h), all of one probe: the
// same viewer and sequence bits 16..63 (kind and probe id), distinct steps.
// Answers: the camera's fragment of each step, back to back, each whole
// (lf/wire/wire.h: its header's payload size says where the next starts), in the
// order of the steps. An older receiver refuses a bundle as a request of
// the wrong size.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/geometry/view.h"
#include "lf/wire/wire.h"

namespace lf {

// The most steps a bundle holds: a surface probe's most planes (a focus
// probe has kFocusProbeSteps).
constexpr size_t kMaxBundleSteps = FocalSurface::kMaxPlanes;
// The most output pixels of one step's view in a bundle (a surface probe is
// SurfaceOptions::analysis_width = 160 pixels wide, a focus probe 33 x 33):
// a camera keeps all its answers to a bundle until the last step, so a
// bundle asks for at most kMaxBundleSteps x 320 x 240 fragment pixels
// (20 MB) whatever a peer puts in it.
constexpr long kMaxBundleStepPixels = 320 * 240;

// Whether a sequence is a probe step (focus or surface), and whether two
// are steps of the same probe.
inline bool is_probe_step(uint64_t sequence) {
  return is_focus_probe(sequence) || is_surface_probe(sequence);
}
inline bool same_probe(uint64_t a, uint64_t b) {
  return is_probe_step(a) && is_probe_step(b) && (a >> 16) == (b >> 16);
}

// The bundle of `steps` (1..kMaxBundleSteps requests of one probe, none
// with a focal surface, each of at most kMaxBundleStepPixels). Throws
// std::invalid_argument otherwise.
std::vector<uint8_t> serialize_probe_bundle(const std::vector<ViewRequest>& steps);
// A request buffer's bytes: one request as itself (lf::serialize_request),
// more as a probe bundle; what parse_requests reads back.
std::vector<uint8_t> serialize_requests(const std::vector<ViewRequest>& requests);

// The requests in a request buffer: one request (lf::parse_request), or a
// probe bundle of 2..kMaxBundleSteps. Throws WireError for anything else: a
// size that is not a whole number of requests, a step of another viewer or
// probe, a frame request in a bundle, a step twice, a step's view over
// kMaxBundleStepPixels; with `sizes`, each
// request's byte count (its offset is the sum of those before it).
std::vector<ViewRequest> parse_requests(const uint8_t* data, size_t size,
                                        std::vector<size_t>* sizes = nullptr);

// The byte ranges of the fragments in an answer buffer, from their headers
// (lf::peek_fragment_header; nothing is decoded or CRC-checked): one
// fragment, a layer pair or a probe bundle, at most `max_count`
// (truncation, a header that does not parse, or more: WireError). What the
// fragments must have in common is the caller's to check.
struct FragmentSpan {
  size_t offset = 0, size = 0;
  FragmentHeader head;
};
std::vector<FragmentSpan> split_fragments(const uint8_t* data, size_t size, size_t max_count);

// The spans of a probe bundle's answer: every fragment a step of the first
// one's probe, of its viewer and camera, each step once. Throws WireError
// otherwise.
std::vector<FragmentSpan> split_probe_answer(const uint8_t* data, size_t size);

// One camera's answer to a frame request, as a compositor takes it: one
// fragment; its layer 0 then its layer 1 (a focal surface with second
// planes, lib/lf/focus/focal_surface.h); or its fragments of a quilt's eyes
// (lib/lf/render/quilt.h: at most Quilt::kMaxViews, each a non-empty layer 0 of
// one camera, in a tile of its own: no two overlap). Every piece is of the
// first one's viewer, request and camera. Parsed in place
// (parse_fragment_in_place, CRC checked when `check_crc`): together the
// pieces carry at most `max_pixels` pixels (a layer pair's two may each
// cover the frame). Throws WireError otherwise.
struct AnswerPiece {
  Fragment f;  // raw pixels stay in `data`: see `pixels`
  Encoding encoding = Encoding::kEmpty;
  const uint8_t* pixels = nullptr;  // raw: inside `data`
};
std::vector<AnswerPiece> parse_frame_answer(const uint8_t* data, size_t size, size_t max_pixels,
                                            bool check_crc = true);

}  // namespace lf
