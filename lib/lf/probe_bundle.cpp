#include "lf/probe_bundle.h"

#include <set>
#include <stdexcept>
#include <string>

namespace lf {

std::vector<uint8_t> serialize_probe_bundle(const std::vector<ViewRequest>& steps) {
  if (steps.empty() || steps.size() > kMaxBundleSteps)
    throw std::invalid_argument("probe bundle of " + std::to_string(steps.size()) + " steps (1.." +
                                std::to_string(kMaxBundleSteps) + ")");
  std::vector<uint8_t> out;
  out.reserve(steps.size() * kRequestSize);
  std::set<uint64_t> seen;
  for (const ViewRequest& r : steps) {
    if (!same_probe(r.sequence, steps[0].sequence) || r.viewer_id != steps[0].viewer_id ||
        !r.surface.empty() || !seen.insert(r.sequence).second ||
        static_cast<long>(r.view.width) * r.view.height > kMaxBundleStepPixels)
      throw std::invalid_argument(
          "probe bundle: every step must be a distinct step of one probe of one viewer, without "
          "a focal surface, of at most " +
          std::to_string(kMaxBundleStepPixels) + " pixels");
    const std::vector<uint8_t> one = serialize_request(r);
    out.insert(out.end(), one.begin(), one.end());
  }
  return out;
}

std::vector<ViewRequest> parse_requests(const uint8_t* data, size_t size,
                                        std::vector<size_t>* sizes) {
  if (sizes) sizes->clear();
  // One request of any version: its own size rules (parse_request).
  if (size <= kRequestSize || size % kRequestSize != 0) {
    if (sizes) sizes->push_back(size);
    return {parse_request(data, size)};
  }
  const size_t n = size / kRequestSize;
  if (n > kMaxBundleSteps) {
    // A version-3 request (a focal surface) is longer than one version-2
    // request; so is a bundle. Try the single request first.
    if (sizes) sizes->push_back(size);
    return {parse_request(data, size)};
  }
  // A multiple of kRequestSize: a bundle, or a version-3 request of that
  // size. The fifth and sixth bytes (the version) say which.
  if (data[4] != 0 || data[5] != 2) {
    if (sizes) sizes->push_back(size);
    return {parse_request(data, size)};
  }
  std::vector<ViewRequest> out;
  out.reserve(n);
  std::set<uint64_t> steps;
  for (size_t k = 0; k < n; ++k) {
    out.push_back(parse_request(data + k * kRequestSize, kRequestSize));
    const ViewRequest& r = out.back();
    if (!same_probe(r.sequence, out[0].sequence) || r.viewer_id != out[0].viewer_id)
      throw WireError("probe bundle: request " + std::to_string(k) + " of " + std::to_string(n) +
                      " is not a step of the first one's probe and viewer");
    if (!steps.insert(r.sequence).second)
      throw WireError("probe bundle: step " + std::to_string(r.sequence & 0xffff) + " twice");
    if (static_cast<long>(r.view.width) * r.view.height > kMaxBundleStepPixels)
      throw WireError("probe bundle: a step of " + std::to_string(r.view.width) + "x" +
                      std::to_string(r.view.height) + " pixels (at most " +
                      std::to_string(kMaxBundleStepPixels) + ")");
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
    const size_t whole = kFragmentHeaderSize + size_t{s.head.payload_size};
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

}  // namespace lf
