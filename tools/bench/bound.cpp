#include "bench/bound.h"

#include <glib.h>

#include <algorithm>
#include <thread>

#include "lf/io/parse.h"
#include "lf/render/composite.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/wire/wire.h"
#include "measure.h"

namespace lfbench {

using measure::median;
using measure::thread_cpu_s;

KernelTime kernel_ms(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                     const lf::ViewSettings& vs, const std::string& focal_plane, int n,
                     const std::vector<int>& jpeg_qualities) {
  const int W = vs.width, H = vs.height;
  const lf::ViewSequence seq = lf::build_views(rig, vs);
  lf::ViewRequest req;
  req.focal_plane = lf::parse_focal_plane(focal_plane, rig);
  std::vector<lf::Fragment> frags(rig.cameras.size());
  std::vector<lf::FragmentPixels> pixels(frags.size());
  std::vector<lf::FragmentPlan> plans(frags.size());
  std::vector<lf::FragmentDrawing> drawings(frags.size());
  std::vector<std::vector<uint8_t>> wire(frags.size());  // JPEG: decoded, raw wire format
  std::vector<uint8_t> rect;                             // JPEG: the rectangle to encode
  std::vector<lf::Fragment> heads(frags.size());
  lf::Compositor comp;
  cv::Mat out;
  // The library's ways, view by view: each fragment rendered, then all
  // composited (way 0); or planned, then drawn band by band into the sums
  // (1: fused, as lfcompositor draws deferred fragments); or rendered, JPEG
  // coded and decoded, then composited (2 + k: jpeg_qualities[k]).
  const int ways = 2 + static_cast<int>(jpeg_qualities.size());
  std::vector<std::vector<double>> ms(ways), cpu(ways);
  for (int k = 0; k < n; ++k) {
    req.view = seq.at(static_cast<uint64_t>(k), rig);
    for (int way = 0; way < ways; ++way) {
      const bool fused = way == 1;
      const gint64 t0 = g_get_monotonic_time();
      const double c0 = thread_cpu_s();
      const lf::ViewGeometry g(rig, req);
      for (size_t i = 0; i < frags.size(); ++i) {
        plans[i] = lf::plan_fragment(g, static_cast<int>(i));
        if (fused) {
          drawings[i] = {&plans[i], &rig.cameras[i], &images[i]};
          continue;
        }
        if (way < 2) {
          lf::render_fragment(plans[i], rig.cameras[i], images[i], frags[i]);
          pixels[i] = {&frags[i], frags[i].pixels.data()};
          continue;
        }
        // As lffragment does on the CPU: drawn straight into the rectangle
        // the encoder takes.
        const lf::FragmentPlan& p = plans[i];
        lf::describe_fragment(p, frags[i]);
        rect.resize(std::max(rect.size(), 4 * static_cast<size_t>(p.rect.area())));
        lf::render_rows(p, rig.cameras[i], images[i], 0, p.rect.height, rect.data(),
                        lf::Kernel::kBest, 4 * static_cast<size_t>(p.rect.width));
        const std::vector<uint8_t> jpeg =
            lf::serialize_jpeg_fragment(frags[i], rect.data(), jpeg_qualities[way - 2]);
        pixels[i] = {&frags[i], nullptr};
        if (frags[i].empty()) continue;
        lf::decode_jpeg_to_raw(jpeg.data(), jpeg.size(), lf::kMaxFragmentPixels, [&](size_t size) {
          wire[i].resize(size);
          return wire[i].data();
        });
        const uint8_t* px = nullptr;
        heads[i] = lf::parse_fragment_in_place(wire[i].data(), wire[i].size(), &px, nullptr,
                                               lf::kMaxFragmentPixels, false);
        pixels[i] = {&heads[i], px};
      }
      // One thread: cv::setNumThreads(1) by the caller.
      if (fused)
        comp.composite(W, H, {}, drawings, out);
      else
        comp.composite(W, H, pixels, out);
      ms[way].push_back((g_get_monotonic_time() - t0) / 1000.0);
      cpu[way].push_back((thread_cpu_s() - c0) * 1000.0);
    }
  }
  KernelTime t;
  t.separate_ms = median(ms[0]);
  t.fused_ms = median(ms[1]);
  const int best = t.fused_ms < t.separate_ms;
  t.wall_ms = best ? t.fused_ms : t.separate_ms;
  t.cpu_ms = median(cpu[best]);
  for (size_t q = 0; q < jpeg_qualities.size(); ++q)
    t.jpeg[jpeg_qualities[q]] = {median(ms[2 + q]), median(cpu[2 + q])};
  return t;
}

double kernel_ms_together(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                          const lf::ViewSettings& vs, const std::string& focal_plane, int n,
                          int threads) {
  std::vector<double> ms(threads, 0);
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&, t] {
      try {
        ms[t] = kernel_ms(rig, images, vs, focal_plane, n, {}).wall_ms;
      } catch (...) {
        ms[t] = 0;  // (kernel_ms alone, on the caller's thread, reports the error)
      }
    });
  for (std::thread& th : pool) th.join();
  if (std::count(ms.begin(), ms.end(), 0.0)) return 0;
  double sum = 0;
  for (double m : ms) sum += m;
  return sum / threads;
}

}  // namespace lfbench
