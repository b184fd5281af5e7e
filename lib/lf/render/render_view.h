// Whole-view rendering on one machine: plan and render every camera's
// fragment and composite them (the paper's finite-viewpoints pipeline,
// Section 3.2, run in-process). Images: one CV_8UC4 per rig camera, in the
// rig's order and at its image sizes.
#pragma once

#include <cstddef>
#include <opencv2/core.hpp>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"

namespace lf {

struct RenderStats {
  size_t fragment_pixels = 0;  // pixels carried by all fragments
  int contributing = 0;        // cameras with a non-empty fragment
  double plan_ms = 0, render_ms = 0, composite_ms = 0;
  // GlRenderer::render_view, of render_ms: the context made current and
  // the sum target cleared, the run tables built and uploaded (CPU), the
  // draw calls issued (a software rasteriser draws in them), the wait for
  // the GPU to draw and resolve (glFinish), and the frame read back
  // (glReadPixels).
  double setup_ms = 0, tables_ms = 0, draw_ms = 0, gpu_ms = 0, readback_ms = 0;
};

// Renders a request. `images[i]` is camera i's CV_8UC4 image. `threads` > 1
// renders fragments of different cameras in parallel (OpenCV's pool).
// Returns CV_8UC4.
cv::Mat render_view(const Rig& rig, const std::vector<cv::Mat>& images, const ViewRequest& req,
                    RenderStats* stats = nullptr, int threads = 1);

}  // namespace lf
