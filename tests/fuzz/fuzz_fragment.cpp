// libFuzzer harness: the fragment parser (lib/lf/wire/wire.h) as a receiver uses
// it (also in place with the CRC waived), then compositing of whatever it
// accepts; and the split of a buffer into fragments (a probe bundle's
// answer, lib/lf/wire/probe_bundle.h): spans back to back covering it exactly,
// each its header's size. A parsed fragment must pass
// check_fragment, survive a raw round trip unchanged, and add to a frame of
// its size without error.
#include <cstdint>
#include <cstdlib>
#include <exception>

#include "lf/render/composite.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  for (const bool probe : {false, true}) {
    std::vector<lf::FragmentSpan> spans;
    try {
      spans = probe ? lf::split_probe_answer(data, size)
                    : lf::split_fragments(data, size, lf::kMaxBundleSteps);
    } catch (const lf::WireError&) {
      continue;
    }
    size_t at = 0;
    for (const lf::FragmentSpan& s : spans) {
      if (s.offset != at || s.size != s.head.size()) std::abort();
      at += s.size;
    }
    if (at != size || spans.empty() || spans.size() > lf::kMaxBundleSteps) std::abort();
  }
  // In place with the CRC waived (as lfcompositor parses buffers sealed in
  // its own process): the fuzzer gets past the checksum, and every other
  // check must still keep the fused compositor safe; a fragment accepted
  // here is never refused by it.
  {
    const uint8_t* px = nullptr;
    lf::Fragment v;
    bool parsed = true;
    try {
      v = lf::parse_fragment_in_place(data, size, &px, nullptr, 640 * 480, false);
    } catch (const lf::WireError&) {
      parsed = false;
    }
    if (parsed) {
      lf::check_fragment_geometry(v);
      if (v.out_width <= 160 && v.out_height <= 120) {  // small frames: many runs a second
        lf::Compositor c;
        cv::Mat out;
        if (!c.composite(v.out_width, v.out_height, {{&v, px}}, out).empty()) std::abort();
      }
    }
  }
  lf::Fragment f;
  try {
    // A receiver's limit: a 640x480 frame.
    f = lf::parse_fragment(data, size, nullptr, 640 * 480);
  } catch (const lf::WireError&) {
    return 0;  // rejected: the expected outcome for almost every input
  }
  lf::check_fragment(f);  // throws (and so aborts the run) if inconsistent
  const auto raw = lf::serialize_fragment(f, f.empty() ? lf::Encoding::kEmpty : lf::Encoding::kRaw);
  const lf::Fragment g = lf::parse_fragment(raw.data(), raw.size());
  if (g.pixels != f.pixels || g.spans != f.spans || g.rect != f.rect) std::abort();
  if (f.out_width <= 640 && f.out_height <= 480) {
    lf::Compositor c;
    c.reset(f.out_width, f.out_height);
    c.add(f);
    cv::Mat out;
    c.resolve(out);
  }
  return 0;
}
