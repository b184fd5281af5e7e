#include "lf/render_view.h"

#include <chrono>
#include <opencv2/core/utility.hpp>
#include <stdexcept>
#include <string>

#include "lf/composite.h"
#include "lf/plan.h"
#include "lf/render.h"

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
  std::vector<FragmentPlan> plans(n);
  std::vector<Fragment> frags(n);
  double t1 = 0, t2 = 0;
  auto work = [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) {
      plans[i] = plan_fragment(g, i);
      frags[i].viewer_id = req.viewer_id;
      frags[i].sequence = req.sequence;
    }
  };
  auto draw = [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i)
      render_fragment(plans[i], rig.cameras[i], images[i], frags[i]);
  };
  if (threads > 1) {
    const int old = cv::getNumThreads();
    cv::setNumThreads(threads);
    cv::parallel_for_(cv::Range(0, n), work);
    t1 = now_ms();
    cv::parallel_for_(cv::Range(0, n), draw);
    cv::setNumThreads(old);
  } else {
    work(cv::Range(0, n));
    t1 = now_ms();
    draw(cv::Range(0, n));
  }
  t2 = now_ms();
  Compositor comp;
  comp.reset(req.view.width, req.view.height);
  RenderStats s;
  for (const Fragment& f : frags) {
    comp.add(f);
    s.fragment_pixels += f.pixel_count();
    s.contributing += f.empty() ? 0 : 1;
  }
  cv::Mat out;
  comp.resolve(out);
  const double t3 = now_ms();
  s.plan_ms = t1 - t0;
  s.render_ms = t2 - t1;
  s.composite_ms = t3 - t2;
  if (stats) *stats = s;
  return out;
}

}  // namespace lf
