// libFuzzer harness: the view request parser, then planning and rendering of
// the parsed view on a small synthetic rig (views capped at 96x96 pixels to
// keep executions fast). The SIMD and scalar kernels must agree bit for bit.
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "lf/plan.h"
#include "lf/render.h"
#include "lf/synthetic.h"
#include "lf/wire.h"

namespace {
struct Scene {
  lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.05, 48, 36, 40.0, 1.0);
  std::vector<cv::Mat> images;
  Scene() {
    const lf::SyntheticScene s = lf::SyntheticScene::for_rig(rig);
    for (const auto& cam : rig.cameras) images.push_back(s.render(cam, 0.3));
  }
};
const Scene& scene() {
  static const Scene s;
  return s;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  lf::ViewRequest req;
  try {
    req = lf::parse_request(data, size);
  } catch (const lf::WireError&) {
    return 0;
  } catch (const std::invalid_argument&) {
    return 0;  // lf::validate's rejections
  }
  if (req.view.width > 96 || req.view.height > 96) return 0;
  const Scene& s = scene();
  const lf::ViewGeometry g(s.rig, req);
  for (int i = 0; i < static_cast<int>(s.rig.cameras.size()); ++i) {
    const lf::FragmentPlan plan = lf::plan_fragment(g, i);
    lf::Fragment b;
    lf::render_fragment(plan, s.rig.cameras[i], s.images[i], b, lf::Kernel::kScalar);
    // Every vector kernel this CPU has, byte for byte against the reference.
    for (lf::Kernel k : {lf::Kernel::kSse2, lf::Kernel::kAvx2}) {
      if (!lf::kernel_available(k)) continue;
      lf::Fragment a;
      lf::render_fragment(plan, s.rig.cameras[i], s.images[i], a, k);
      if (a.pixels != b.pixels || a.spans != b.spans || a.rect != b.rect) std::abort();
    }
  }
  return 0;
}
