#include "lf/wire/probe_bundle.h"

#include <algorithm>
#include <set>
#include <stdexcept>
#include <string>

#include "lf/render/quilt.h"

namespace lf {

namespace {
// Why step `r` cannot join a bundle whose first step is `first` and whose
// steps so far are `seen` (which it joins); empty if it can.
std::string step_problem(const ViewRequest& r, const ViewRequest& first, std::set<uint64_t>& seen) {
  if (!same_probe(r.sequence, first.sequence) || r.viewer_id != first.viewer_id)
    return "a request that is not a step of the first one's probe and viewer";
  if (!r.surface.empty()) return "a step with a focal surface";
  if (!seen.insert(r.sequence).second)
    return "step " + std::to_string(r.sequence & 0xffff) + " twice";
  if (static_cast<long>(r.view.width) * r.view.height > kMaxBundleStepPixels)
    return "a step of " + std::to_string(r.view.width) + "x" + std::to_string(r.view.height) +
           " pixels (at most " + std::to_string(kMaxBundleStepPixels) + ")";
  return "";
}
}  // namespace

std::vector<uint8_t> serialize_probe_bundle(const std::vector<ViewRequest>& steps) {
  if (steps.empty() || steps.size() > kMaxBundleSteps)
    throw std::invalid_argument("probe bundle of " + std::to_string(steps.size()) + " steps (1.." +
                                std::to_string(kMaxBundleSteps) + ")");
  std::vector<uint8_t> out;
  out.reserve(steps.size() * kRequestSize);
  std::set<uint64_t> seen;
  for (const ViewRequest& r : steps) {
    const std::string why = step_problem(r, steps[0], seen);
    if (!why.empty()) throw std::invalid_argument("probe bundle: " + why);
    const std::vector<uint8_t> one = serialize_request(r);
    out.insert(out.end(), one.begin(), one.end());
  }
  return out;
}

std::vector<ViewRequest> parse_requests(const uint8_t* data, size_t size,
                                        std::vector<size_t>* sizes) {
  if (sizes) sizes->clear();
  // One request of any version, by its own size rules (parse_request),
  // unless the buffer is 2..kMaxBundleSteps version-2 requests: a version-3
  // request (a focal surface) may also be a multiple of kRequestSize long,
  // and its version (bytes 4..5) says so.
  const size_t n = size / kRequestSize;
  if (size % kRequestSize != 0 || n < 2 || n > kMaxBundleSteps || data[4] != 0 || data[5] != 2) {
    if (sizes) sizes->push_back(size);
    return {parse_request(data, size)};
  }
  std::vector<ViewRequest> out;
  out.reserve(n);
  std::set<uint64_t> seen;
  for (size_t k = 0; k < n; ++k) {
    out.push_back(parse_request(data + k * kRequestSize, kRequestSize));
    const std::string why = step_problem(out.back(), out[0], seen);
    if (!why.empty())
      throw WireError("probe bundle: request " + std::to_string(k) + " of " + std::to_string(n) +
                      ": " + why);
    if (sizes) sizes->push_back(kRequestSize);
  }
  return out;
}

std::vector<FragmentSpan> split_fragments(const uint8_t* data, size_t size, size_t max_count) {
  std::vector<FragmentSpan> out;
  size_t at = 0;
  do {
    if (out.size() == max_count)
      throw WireError("fragment buffer: more than " + std::to_string(max_count) + " fragments");
    FragmentSpan s;
    s.offset = at;
    s.head = peek_fragment_header(data + at, size - at);
    const size_t whole = s.head.size();
    if (whole > size - at)
      throw WireError("fragment buffer: fragment " + std::to_string(out.size()) + " of " +
                      std::to_string(whole) + " bytes, " + std::to_string(size - at) + " left");
    s.size = whole;
    at += whole;
    out.push_back(s);
  } while (at < size);
  return out;
}

std::vector<FragmentSpan> split_probe_answer(const uint8_t* data, size_t size) {
  std::vector<FragmentSpan> spans = split_fragments(data, size, kMaxBundleSteps);
  const FragmentHeader& h0 = spans[0].head;
  std::set<uint64_t> steps;
  for (const FragmentSpan& s : spans)
    if (!same_probe(s.head.sequence, h0.sequence) || s.head.viewer_id != h0.viewer_id ||
        s.head.camera_id != h0.camera_id || s.head.layer != 0 ||
        !steps.insert(s.head.sequence).second)
      throw WireError(
          "probe answer: every fragment must be a distinct step of one probe, of one viewer and "
          "camera");
  return spans;
}

std::vector<AnswerPiece> parse_frame_answer(const uint8_t* data, size_t size, size_t max_pixels,
                                            bool check_crc) {
  const std::vector<FragmentSpan> spans = split_fragments(data, size, Quilt::kMaxViews);
  std::vector<AnswerPiece> out;
  out.reserve(spans.size());
  size_t pixels_left = max_pixels;
  for (const FragmentSpan& sp : spans) {
    AnswerPiece a;
    const size_t limit = spans.size() == 2 ? max_pixels : pixels_left;
    a.f = parse_fragment_in_place(data + sp.offset, sp.size, &a.pixels, &a.encoding, limit,
                                  check_crc);
    pixels_left -= std::min(pixels_left, static_cast<size_t>(a.f.rect.area()));
    if (!out.empty()) {
      const Fragment& f0 = out.front().f;
      const bool layer_pair = spans.size() == 2 && f0.layer == 0 && a.f.layer == 1;
      auto apart = [&](const AnswerPiece& o) { return (o.f.rect & a.f.rect).area() == 0; };
      const bool quilt_eye = f0.layer == 0 && a.f.layer == 0 && !f0.empty() && !a.f.empty() &&
                             f0.cameras == 1 && a.f.cameras == 1 &&
                             std::all_of(out.begin(), out.end(), apart);
      if (!(layer_pair || quilt_eye) || a.f.viewer_id != f0.viewer_id ||
          a.f.sequence != f0.sequence || a.f.camera_id != f0.camera_id)
        throw WireError(
            "fragment: a buffer's further fragments must be the same camera's layer 1 of the "
            "same request, after its layer 0, or its fragments of other eyes of the same quilt "
            "request, each in a tile of its own");
    }
    out.push_back(std::move(a));
  }
  return out;
}

std::vector<uint8_t> serialize_requests(const std::vector<ViewRequest>& requests) {
  return requests.size() == 1 ? serialize_request(requests[0]) : serialize_probe_bundle(requests);
}

}  // namespace lf
