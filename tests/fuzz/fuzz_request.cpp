// libFuzzer harness: the view request parser (one request or a probe bundle,
// lib/lf/wire/probe_bundle.h), then planning and rendering of the first parsed
// view on a small synthetic rig (views capped at 96x96 pixels to keep
// executions fast). The SIMD and scalar kernels must agree bit for bit; a
// bundle must be distinct steps of one probe and viewer, and its bytes must
// serialize back as they came.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <set>

#include "lf/quality/synthetic.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"

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
  std::vector<lf::ViewRequest> reqs;
  try {
    reqs = lf::parse_requests(data, size);
  } catch (const lf::WireError&) {
    return 0;
  } catch (const std::invalid_argument&) {
    return 0;  // lf::validate's rejections
  }
  if (reqs.empty() || reqs.size() > lf::kMaxBundleSteps) std::abort();
  if (reqs.size() > 1) {
    std::set<uint64_t> steps;
    for (const lf::ViewRequest& r : reqs)
      if (!lf::same_probe(r.sequence, reqs[0].sequence) || r.viewer_id != reqs[0].viewer_id ||
          !steps.insert(r.sequence).second)
        std::abort();
    if (lf::parse_requests(lf::serialize_probe_bundle(reqs).data(), size).size() != reqs.size())
      std::abort();
  }
  const lf::ViewRequest& req = reqs[0];
  if (req.view.width > 96 || req.view.height > 96) return 0;
  const Scene& s = scene();
  const lf::ViewGeometry g(s.rig, req);
  for (int i = 0; i < static_cast<int>(s.rig.cameras.size()); ++i) {
    const lf::FragmentPlan plan = lf::plan_fragment(g, i);
    lf::Fragment b;
    lf::render_fragment(plan, s.rig.cameras[i], s.images[i], b, lf::Kernel::kScalar);
    // Every vector kernel this CPU has, byte for byte against the reference.
    for (lf::Kernel k : {lf::Kernel::kSse2, lf::Kernel::kAvx2, lf::Kernel::kAvx512}) {
      if (!lf::kernel_available(k)) continue;
      lf::Fragment a;
      lf::render_fragment(plan, s.rig.cameras[i], s.images[i], a, k);
      if (a.pixels != b.pixels || a.spans != b.spans || a.rect != b.rect) std::abort();
    }
  }
  return 0;
}
