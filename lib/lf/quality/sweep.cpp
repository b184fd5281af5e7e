#include "lf/quality/sweep.h"

#include <algorithm>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "lf/focus/focal_surface.h"
#include "lf/focus/focus.h"
#include "lf/render/fragment.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"

namespace lf {

SweepResult per_pixel_sweep(const Rig& rig, const std::vector<cv::Mat>& images,
                            const ViewRequest& req, int planes, int window) {
  if (planes < 2) throw std::invalid_argument("per_pixel_sweep: planes < 2");
  if (window < 1 || window % 2 == 0)
    throw std::invalid_argument("per_pixel_sweep: the window must be odd and positive");
  if (images.size() != rig.cameras.size())
    throw std::invalid_argument("per_pixel_sweep: one image per camera needed");
  const int W = req.view.width, H = req.view.height;
  SweepResult out;
  out.image = cv::Mat::zeros(H, W, CV_8UC4);
  out.plane = cv::Mat::zeros(H, W, CV_16UC1);
  cv::Mat best(H, W, CV_32FC1, cv::Scalar(std::numeric_limits<float>::infinity()));
  const double q_max = sweep_q_max(rig, SurfaceOptions{});
  // Per pixel: sum w, sum w c (3), sum w |c|^2, with w = alpha / 255.
  cv::Mat sums(H, W, CV_32FC(5)), cost(H, W, CV_32FC1), mean(H, W, CV_32FC3);
  Fragment f;
  for (int k = 0; k < planes; ++k) {
    const double q = q_max * k / (planes - 1);
    out.qs.push_back(q);
    ViewRequest r = req;
    r.surface = FocalSurface{};
    r.focal_plane = plane_at_inverse_depth(rig, q);
    const ViewGeometry g(rig, r);
    std::fill(sums.ptr<float>(), sums.ptr<float>() + sums.total() * 5, 0.0f);
    for (size_t i = 0; i < rig.cameras.size(); ++i) {
      const FragmentPlan plan = plan_fragment(g, static_cast<int>(i));
      if (plan.empty()) continue;
      render_fragment(plan, rig.cameras[i], images[i], f);
      const uint8_t* px = f.pixels.data();
      for (int row = 0; row < f.rect.height; ++row) {
        float* s = sums.ptr<float>(f.rect.y + row);
        for (int x = f.spans[row][0]; x < f.spans[row][1]; ++x, px += 4) {
          if (px[3] == 0) continue;
          const float w = px[3] / 255.0f;  // c = px / w
          float* p = s + 5 * x;
          p[0] += w;
          float q2 = 0;
          for (int c = 0; c < 3; ++c) p[1 + c] += px[c], q2 += float(px[c]) * px[c];
          p[4] += q2 / w;
        }
      }
    }
    for (int y = 0; y < H; ++y) {
      const float* s = sums.ptr<float>(y);
      float* co = cost.ptr<float>(y);
      float* m = mean.ptr<float>(y);
      for (int x = 0; x < W; ++x, s += 5) {
        if (s[0] <= 0) {
          co[x] = 1e6f, m[3 * x] = m[3 * x + 1] = m[3 * x + 2] = -1;
          continue;
        }
        float m2 = 0;
        for (int c = 0; c < 3; ++c)
          m[3 * x + c] = s[1 + c] / s[0], m2 += m[3 * x + c] * m[3 * x + c];
        co[x] = std::max(0.0f, s[4] / s[0] - m2);
      }
    }
    cv::blur(cost, cost, cv::Size(window, window), cv::Point(-1, -1), cv::BORDER_REPLICATE);
    for (int y = 0; y < H; ++y) {
      const float* co = cost.ptr<float>(y);
      const float* m = mean.ptr<float>(y);
      float* b = best.ptr<float>(y);
      uint8_t* o = out.image.ptr<uint8_t>(y);
      uint16_t* pl = out.plane.ptr<uint16_t>(y);
      for (int x = 0; x < W; ++x) {
        if (m[3 * x] < 0 || co[x] >= b[x]) continue;
        b[x] = co[x], pl[x] = static_cast<uint16_t>(k);
        for (int c = 0; c < 3; ++c) o[4 * x + c] = cv::saturate_cast<uint8_t>(m[3 * x + c]);
        o[4 * x + 3] = 255;
      }
    }
  }
  return out;
}

}  // namespace lf
