// lf-bench's speed tables: one core, side by side in the same repetitions.
#include "bench/speed.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <string>

#include "lf/geometry/rig_ops.h"
#include "lf/geometry/view_builder.h"
#include "lf/render/gl_render.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"
#include "measure.h"

namespace lfbench {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}
using measure::median;

}  // namespace

void speed_table(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                 const std::vector<lf::ViewRequest>& path, int W0, int H0) {
  // Every fragment kernel this CPU and build have, side by side with
  // OpenCV in the same repetitions (the best one is what the elements use);
  // AVX-512's with each way of reading its taps (lf::TapLoads; the
  // elements use the self-timed one).
  struct Way {
    lf::Kernel kernel;
    lf::TapLoads taps;
  };
  std::vector<Way> kernels;
  for (lf::Kernel k : {lf::Kernel::kScalar, lf::Kernel::kSse2, lf::Kernel::kAvx2})
    if (lf::kernel_available(k)) kernels.push_back({k, lf::TapLoads::kAuto});
  if (lf::kernel_available(lf::Kernel::kAvx512))
    for (lf::TapLoads t : {lf::TapLoads::kGather, lf::TapLoads::kLoads})
      kernels.push_back({lf::Kernel::kAvx512, t});
  const lf::TapLoads used_taps = lf::tap_loads();  // timed here, before the runs
  auto name = [](const Way& w) {
    return std::string(lf::kernel_name(w.kernel)) + " kernel" +
           (w.taps == lf::TapLoads::kAuto ? ""
                                          : std::string(", taps by ") + lf::tap_loads_name(w.taps));
  };
  std::vector<std::vector<double>> ours_ms(kernels.size());
  std::vector<double> warp_ms, naive_ms, plan_ms;
  size_t frag_px = 0, warp_px = 0;
  const int nviews = std::min<int>(8, path.size());
  for (int rep = 0; rep < 5; ++rep) {
    std::vector<double> ours(kernels.size(), 0.0);
    double warp = 0, naive = 0, planning = 0;
    frag_px = warp_px = 0;
    for (int v = 0; v < nviews; ++v) {
      const lf::ViewRequest& req = path[v * path.size() / nviews];
      // Ours: plan and render every camera's fragment.
      std::vector<lf::FragmentPlan> plans(rig.cameras.size());
      std::vector<lf::Fragment> frags(rig.cameras.size());
      for (size_t ki = 0; ki < kernels.size(); ++ki) {
        lf::set_tap_loads(kernels[ki].taps);
        const auto t0 = Clock::now();
        const lf::ViewGeometry g(rig, req);
        for (size_t i = 0; i < rig.cameras.size(); ++i) {
          plans[i] = lf::plan_fragment(g, static_cast<int>(i));
          lf::render_fragment(plans[i], rig.cameras[i], images[i], frags[i], kernels[ki].kernel);
        }
        ours[ki] += ms_since(t0);
      }
      lf::set_tap_loads(lf::TapLoads::kAuto);
      // Planning alone (the share of "ours" that no kernel does).
      auto t0 = Clock::now();
      const lf::ViewGeometry g(rig, req);
      for (size_t i = 0; i < rig.cameras.size(); ++i)
        plans[i] = lf::plan_fragment(g, static_cast<int>(i));
      planning += ms_since(t0);
      // OpenCV warpPerspective for the same number of output pixels: each
      // non-empty fragment's homography into a destination of as many
      // pixels as the fragment carries (its rectangle's width).
      cv::Mat dst;
      t0 = Clock::now();
      for (size_t i = 0; i < rig.cameras.size(); ++i) {
        const auto& p = plans[i];
        if (p.empty()) continue;
        const size_t n = p.pixel_count();
        frag_px += n;
        const int w = p.rect.width, h = static_cast<int>((n + w - 1) / w);
        warp_px += static_cast<size_t>(w) * h;
        const cv::Matx33d T(1, 0, p.rect.x, 0, 1, p.rect.y, 0, 0, 1);
        cv::warpPerspective(images[i], dst, cv::Mat(p.pieces[0].H * T), cv::Size(w, h),
                            cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT);
      }
      warp += ms_since(t0);
      // Naive: every camera warped to the full frame, weighted, blended.
      t0 = Clock::now();
      cv::Mat acc(req.view.height, req.view.width, CV_32FC4, cv::Scalar::all(0));
      cv::Mat weight(req.view.height, req.view.width, CV_32F);
      for (size_t i = 0; i < rig.cameras.size(); ++i) {
        cv::warpPerspective(images[i], dst, cv::Mat(g.homography(static_cast<int>(i))), acc.size(),
                            cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_CONSTANT);
        weight.setTo(0);
        for (const auto& r : plans[i].runs) {
          const auto& pc = plans[i].pieces[r.piece];
          float* wr = weight.ptr<float>(r.y);
          for (int x = r.x0; x < r.x1; ++x)
            wr[x] = static_cast<float>(pc.weight_num(x, r.y) / pc.weight_den(x, r.y));
        }
        for (int y = 0; y < acc.rows; ++y) {
          float* a = acc.ptr<float>(y);
          const uint8_t* s = dst.ptr<uint8_t>(y);
          const float* wr = weight.ptr<float>(y);
          for (int x = 0; x < acc.cols; ++x)
            for (int c = 0; c < 4; ++c) a[4 * x + c] += wr[x] * s[4 * x + c];
        }
      }
      naive += ms_since(t0);
    }
    for (size_t ki = 0; ki < kernels.size(); ++ki) ours_ms[ki].push_back(ours[ki] / nviews);
    warp_ms.push_back(warp / nviews);
    naive_ms.push_back(naive / nviews);
    plan_ms.push_back(planning / nviews);
  }
  const double w = median(warp_ms), nv = median(naive_ms);
  const double w_same = w * static_cast<double>(frag_px) / warp_px;
  std::printf(
      "\n## Speed, one core, %zu cameras, %dx%d, %d views on the dolly orbit (median of 5)\n\n",
      rig.cameras.size(), W0, H0, nviews);
  std::printf("CPU: %s, %d cores.\n\n", measure::cpu_model().c_str(), cv::getNumberOfCPUs());
  std::printf(
      "| method | ms per view | output pixels per view | / warpPerspective |\n"
      "|---|---|---|---|\n");
  double o = 0;
  for (size_t ki = 0; ki < kernels.size(); ++ki) {
    const double m = median(ours_ms[ki]);
    const Way& k = kernels[ki];
    const bool best =
        k.kernel == lf::best_kernel() && (k.taps == lf::TapLoads::kAuto || k.taps == used_taps);
    if (best) o = m;
    std::printf("| ours: plan + render all fragments, %s%s | %.2f | %zu | %.2f |\n",
                name(k).c_str(), best ? " (used)" : "", m, frag_px / nviews, m / w_same);
  }
  std::printf("| OpenCV warpPerspective, same pixel count | %.2f | %zu | 1 |\n", w_same,
              frag_px / nviews);
  std::printf("| naive: full-frame warp of every camera + blend | %.2f | %zu | %.1f |\n", nv,
              rig.cameras.size() * static_cast<size_t>(W0) * H0, nv / w_same);
  std::printf(
      "\nOf ours, planning (ViewGeometry + plan_fragment of every camera): %.2f ms "
      "per view.\n",
      median(plan_ms));
  std::printf(
      "\nours (%s) / warpPerspective = %.2f (target <= 0.6); naive / ours = %.1f (target >= "
      "15)\n",
      lf::kernel_name(lf::best_kernel()), o / w_same, nv / o);
  if (lf::best_kernel() == lf::Kernel::kAvx512)
    std::printf(
        "\nThe AVX-512 kernel's taps: by %s on this CPU (lf::tap_loads(), timed at the first "
        "render).\n",
        lf::tap_loads_name(used_taps));
}

// Whole views from all cameras, each backend side by side in the same
// repetitions: CPU lf::render_view on every core; GL GlRenderer::render_view
// with the images uploaded once (the upload of all of them is timed apart:
// a live pipeline pays it once per captured frame, not per view).
void backend_table(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                   const std::vector<lf::Backend>& backends,
                   const std::vector<std::pair<int, int>>& sizes, const lf::FocalPlane& plane) {
  std::unique_ptr<lf::GlRenderer> gl;
  double upload_ms = 0;
  for (lf::Backend b : backends)
    if (b == lf::Backend::kGl && !gl) {
      gl = std::make_unique<lf::GlRenderer>();
      const auto t0 = Clock::now();
      for (size_t i = 0; i < images.size(); ++i) gl->set_image(static_cast<int>(i), images[i]);
      upload_ms = ms_since(t0);
    }
  const int threads = cv::getNumberOfCPUs();
  std::printf("\n## Backends: whole views from %zu cameras, 8 views on an orbit (median of 5)\n\n",
              rig.cameras.size());
  std::printf("CPU: %d threads (%s kernel). GL: %s (%s)%s.\n\n", threads,
              lf::kernel_name(lf::best_kernel()), gl ? lf::gl_info().renderer.c_str() : "not used",
              gl ? lf::gl_info().version.c_str() : "-",
              gl ? (", images uploaded once in " + std::to_string(static_cast<int>(upload_ms)) +
                    " ms for all cameras")
                       .c_str()
                 : "");
  std::printf(
      "| size | backend | ms per view | views per s | / cpu | max abs diff to cpu | GL: plan, "
      "context and clear, tables, draw calls, GPU, read back, the rest (ms) |\n"
      "|---|---|---|---|---|---|---|\n");
  const auto keys = lf::orbit_path(rig, 0.5, 2.0 * rig.typical_spacing(), 24);
  for (const auto& [W, H] : sizes) {
    const auto views = lf::sample_path(rig, keys, 24, W, H, true);
    std::vector<lf::ViewRequest> reqs;
    for (int v = 0; v < 8; ++v) {
      lf::ViewRequest r;
      r.sequence = v;
      r.view = views[v * views.size() / 8];
      r.focal_plane = plane;
      reqs.push_back(r);
    }
    std::vector<std::vector<double>> ms(backends.size());
    std::vector<double> max_diff(backends.size(), 0);
    std::vector<double> split[7];  // GL: plan, setup, tables, draw calls, GPU, read back, rest
    for (int rep = 0; rep < 5; ++rep) {
      std::vector<cv::Mat> cpu_out(reqs.size());
      for (size_t b = 0; b < backends.size(); ++b) {
        const auto t0 = Clock::now();
        for (size_t v = 0; v < reqs.size(); ++v) {
          lf::RenderStats st;
          const bool on_gl = backends[b] == lf::Backend::kGl;
          const auto v0 = Clock::now();
          const cv::Mat out = on_gl ? gl->render_view(rig, reqs[v], &st, threads)
                                    : lf::render_view(rig, images, reqs[v], nullptr, threads);
          if (on_gl && rep > 0) {
            const double parts[6] = {st.plan_ms, st.setup_ms, st.tables_ms,
                                     st.draw_ms, st.gpu_ms,   st.readback_ms};
            double rest = ms_since(v0);
            for (int k = 0; k < 6; ++k) split[k].push_back(parts[k]), rest -= parts[k];
            split[6].push_back(rest);  // the context released, the rest
          }
          if (rep > 0) continue;
          if (backends[b] == lf::Backend::kCpu && cpu_out[v].empty()) cpu_out[v] = out;
          if (!cpu_out[v].empty()) {
            cv::Mat d;
            cv::absdiff(out, cpu_out[v], d);
            double mx = 0;
            cv::minMaxLoc(d.reshape(1), nullptr, &mx);
            max_diff[b] = std::max(max_diff[b], mx);
          }
        }
        ms[b].push_back(ms_since(t0) / reqs.size());
      }
    }
    const auto cpu_at = std::find(backends.begin(), backends.end(), lf::Backend::kCpu);
    const double cpu_ms = cpu_at == backends.end() ? 0 : median(ms[cpu_at - backends.begin()]);
    for (size_t b = 0; b < backends.size(); ++b) {
      const double m = median(ms[b]);
      const std::string gl_split =
          backends[b] == lf::Backend::kGl && !split[0].empty()
              ? cv::format("%.1f, %.1f, %.1f, %.1f, %.1f, %.1f, %.1f", median(split[0]),
                           median(split[1]), median(split[2]), median(split[3]), median(split[4]),
                           median(split[5]), median(split[6]))
              : std::string("-");
      std::printf("| %dx%d | %s | %.1f | %.1f | %s | %s | %s |\n", W, H,
                  lf::backend_name(backends[b]), m, 1000.0 / m,
                  cpu_ms > 0 ? cv::format("%.2f", m / cpu_ms).c_str() : "-",
                  cpu_ms > 0 ? cv::format("%.0f", max_diff[b]).c_str() : "-", gl_split.c_str());
    }
  }
}

}  // namespace lfbench
