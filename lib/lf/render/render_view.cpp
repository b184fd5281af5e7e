#include "lf/render/render_view.h"

#include <chrono>
#include <opencv2/core/utility.hpp>
#include <stdexcept>
#include <string>

#include "lf/render/composite.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"

namespace lf {

namespace {
double now_ms() {
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}
}  // namespace

cv::Mat render_view(const Rig& rig, const std::vector<cv::Mat>& images, const ViewRequest& req,
                    RenderStats* stats, int threads) {
  if (images.size() != rig.cameras.size())
    throw std::invalid_argument("render_view: " + std::to_string(images.size()) + " images for " +
                                std::to_string(rig.cameras.size()) + " cameras");
  const double t0 = now_ms();
  const ViewGeometry g(rig, req);
  const int n = static_cast<int>(rig.cameras.size());
  // Fragment k: camera k % n in layer k / n (layer 1: a surface's second
  // planes, lf/render/plan.h).
  const int layers = req.surface.two_planes() ? 2 : 1;
  std::vector<FragmentPlan> plans(n * layers);
  std::vector<Fragment> frags(n * layers);
  double t1 = 0, t2 = 0;
  auto work = [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) {
      if (layers == 1) {
        plans[i] = plan_fragment(g, i);
      } else {
        auto both = plan_fragment_layers(g, i);
        plans[i] = std::move(both[0]);
        plans[n + i] = std::move(both[1]);
      }
      for (int k = i; k < n * layers; k += n) {
        frags[k].viewer_id = req.viewer_id;
        frags[k].sequence = req.sequence;
      }
    }
  };
  auto draw = [&](const cv::Range& r) {
    for (int k = r.start; k < r.end; ++k)
      render_fragment(plans[k], rig.cameras[k % n], images[k % n], frags[k]);
  };
  const cv::Range all(0, n * layers);
  if (threads > 1) {
    const int old = cv::getNumThreads();
    cv::setNumThreads(threads);
    cv::parallel_for_(cv::Range(0, n), work);
    t1 = now_ms();
    cv::parallel_for_(all, draw);
    cv::setNumThreads(old);
  } else {
    work(cv::Range(0, n));
    t1 = now_ms();
    draw(all);
  }
  t2 = now_ms();
  RenderStats s;
  for (int k = 0; k < n * layers; ++k) {
    s.fragment_pixels += frags[k].pixel_count();
    s.contributing += k < n && !frags[k].empty() ? 1 : 0;
  }
  cv::Mat out;
  if (layers == 1) {
    Compositor comp;
    comp.reset(req.view.width, req.view.height);
    for (const Fragment& f : frags) comp.add(f);
    comp.resolve(out);
  } else {
    std::vector<FragmentPixels> all_pixels;
    for (const Fragment& f : frags) all_pixels.push_back({&f, f.pixels.data()});
    LayerCompositor comp;
    const auto refused = comp.composite(req.view.width, req.view.height, all_pixels, out);
    if (!refused.empty()) throw std::invalid_argument(refused.front().second);
  }
  const double t3 = now_ms();
  s.plan_ms = t1 - t0;
  s.render_ms = t2 - t1;
  s.composite_ms = t3 - t2;
  if (stats) *stats = s;
  return out;
}

}  // namespace lf
