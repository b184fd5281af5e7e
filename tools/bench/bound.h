// lf-gst-bench's kernel bound: the library's plan + render + composite of
// the pipeline's views on one thread, and on every core at once.
#pragma once

#include <algorithm>
#include <map>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view_builder.h"

namespace lfbench {

// Milliseconds per view of the library's ways.
struct KernelTime {
  double wall_ms = 0, cpu_ms = 0;  // the faster way's
  double separate_ms = 0, fused_ms = 0;
  std::map<int, std::pair<double, double>> jpeg;  // quality -> wall ms, CPU ms
  // Each the smaller of this and `o`.
  void keep_faster(const KernelTime& o) {
    wall_ms = std::min(wall_ms, o.wall_ms), cpu_ms = std::min(cpu_ms, o.cpu_ms);
    separate_ms = std::min(separate_ms, o.separate_ms), fused_ms = std::min(fused_ms, o.fused_ms);
    for (auto& [q, t] : jpeg) {
      const auto it = o.jpeg.find(q);
      if (it != o.jpeg.end())
        t = {std::min(t.first, it->second.first), std::min(t.second, it->second.second)};
    }
  }
  // Each the mean of this and `o` (two measurements bracketing a run, so
  // that the machine's drift between them cancels to first order).
  KernelTime mean_with(const KernelTime& o) const {
    KernelTime m = *this;
    m.wall_ms = (wall_ms + o.wall_ms) / 2, m.cpu_ms = (cpu_ms + o.cpu_ms) / 2;
    m.separate_ms = (separate_ms + o.separate_ms) / 2, m.fused_ms = (fused_ms + o.fused_ms) / 2;
    for (auto& [q, t] : m.jpeg) {
      const auto it = o.jpeg.find(q);
      if (it != o.jpeg.end())
        t = {(t.first + it->second.first) / 2, (t.second + it->second.second) / 2};
    }
    return m;
  }
};

// The views `vs` through `focal_plane` (lf::parse_focal_plane), planned,
// rendered and composited by the library on this thread with its buffers
// kept from view to view, as the elements keep theirs: the median per view
// over the first `n`, wall clock and this thread's CPU time, of each way:
// each fragment rendered, then all composited; or planned, then drawn band
// by band into the sums (fused, as lfcompositor draws deferred fragments);
// and, for each of `jpeg_qualities`, rendered, JPEG coded and decoded, then
// composited. OpenCV single-threaded is the caller's (cv::setNumThreads(1)).
KernelTime kernel_ms(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                     const lf::ViewSettings& vs, const std::string& focal_plane, int n,
                     const std::vector<int>& jpeg_qualities);

// kernel_ms's raw ways run on `threads` threads at once, each its own
// views: each thread's faster way's median ms per view, averaged. Against
// kernel_ms alone it says how much running on every core at once slows
// each (caches, memory and the cores' clocks shared): the kernel bound
// (cores / one core's time) assumes it does not.
double kernel_ms_together(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                          const lf::ViewSettings& vs, const std::string& focal_plane, int n,
                          int threads);

}  // namespace lfbench
