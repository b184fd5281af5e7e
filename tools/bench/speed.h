// lf-bench's speed tables (tools/lf-bench.cpp): printed as Markdown.
#pragma once

#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"
#include "lf/render/gl_render.h"

namespace lfbench {

// One core: ours (plan + render every camera's fragment, each kernel this
// CPU has) against OpenCV's warpPerspective for the same output pixels and
// against the naive full-frame warp and blend, over up to 8 views of `path`
// (W0 x H0), median of 5 repetitions.
void speed_table(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                 const std::vector<lf::ViewRequest>& path, int W0, int H0);

// Whole views from all cameras, each backend side by side in the same
// repetitions: CPU lf::render_view on every core; GL GlRenderer::render_view
// with the images uploaded once (the upload of all of them is timed apart:
// a live pipeline pays it once per captured frame, not per view).
void backend_table(const lf::Rig& rig, const std::vector<cv::Mat>& images,
                   const std::vector<lf::Backend>& backends,
                   const std::vector<std::pair<int, int>>& sizes, const lf::FocalPlane& plane);

}  // namespace lfbench
