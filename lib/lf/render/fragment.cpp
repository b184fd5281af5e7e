#include "lf/render/fragment.h"

#include <stdexcept>
#include <string>

namespace lf {

namespace {
[[noreturn]] void bad_fragment(const Fragment& f, const std::string& what) {
  throw std::invalid_argument("fragment from camera " + std::to_string(f.camera_id) + ": " + what);
}
}  // namespace

size_t check_fragment_geometry(const Fragment& f) {
  auto bad = [&](const std::string& what) { bad_fragment(f, what); };
  if (f.out_width < 1 || f.out_height < 1 || f.out_width > 16384 || f.out_height > 16384)
    bad("output size out of range");
  if (f.cameras < 1 || f.cameras > kMaxSummedCameras)
    bad("sums " + std::to_string(f.cameras) + " cameras (1.." + std::to_string(kMaxSummedCameras) +
        ")");
  if (f.weight_shift > kMaxWeightShift)
    bad("weight shift " + std::to_string(f.weight_shift) + " over " +
        std::to_string(kMaxWeightShift));
  if (f.empty()) {
    if (!f.spans.empty()) bad("empty fragment carries data");
    return 0;
  }
  const cv::Rect& r = f.rect;
  if (r.x < 0 || r.y < 0 || r.width <= 0 || r.height <= 0 || r.x + r.width > f.out_width ||
      r.y + r.height > f.out_height)
    bad("rectangle lies outside the " + std::to_string(f.out_width) + "x" +
        std::to_string(f.out_height) + " output");
  if (f.spans.size() != static_cast<size_t>(r.height))
    bad("has " + std::to_string(f.spans.size()) + " row spans for " + std::to_string(r.height) +
        " rows");
  size_t n = 0;
  for (const auto& s : f.spans) {
    if (s[0] > s[1] || s[0] < r.x || s[1] > r.x + r.width) bad("row span outside its rectangle");
    n += s[1] - s[0];
  }
  return n;
}

void check_fragment(const Fragment& f) {
  const size_t n = check_fragment_geometry(f);
  if (f.pixels.size() != 4 * n)
    bad_fragment(f, f.empty() ? std::string("empty fragment carries data")
                              : "pixel data is " + std::to_string(f.pixels.size()) +
                                    " bytes, spans need " + std::to_string(4 * n));
}

}  // namespace lf
