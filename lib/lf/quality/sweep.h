// A per-pixel plane sweep: the reference that a focal surface is measured
// against on scenes with thin structures (issue: "within 0.5 dB of a
// per-pixel sweep"). Beyond the paper, which focuses a whole view on one
// plane (Yang et al. 2002, Section 4.3).
//
// Method: `planes` planes parallel to the camera plane, evenly spaced in
// inverse depth from 0 to sweep_q_max(rig, SurfaceOptions{}) (the focal
// surface's own range, lf/focus/focal_surface.h). Through each, every
// camera's fragment is drawn with the request's aperture and sampling
// (lf/render/plan.h, lf/render/render.h); per output pixel the cameras'
// weighted mean colour and weighted colour variance (8-bit levels^2, summed
// over the three colour channels) follow. The variance is averaged over a
// `window` x `window` box of pixels (photo-consistency of a small patch, as
// stereo matching does) and each pixel takes the mean colour of the plane
// where that is lowest. It costs `planes` whole renders of the view: a
// reference, not a real-time mode.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"

namespace lf {

struct SweepResult {
  cv::Mat image;           // CV_8UC4, the view (alpha 255 where any camera sees, else 0)
  cv::Mat plane;           // CV_16UC1, the chosen plane per pixel (0 .. planes - 1)
  std::vector<double> qs;  // the planes' inverse depths, rig units^-1
};

// `images`: CV_8UC4, one per rig camera. The request's focal plane and
// surface are ignored. Throws std::invalid_argument for planes < 2, an
// even or non-positive window, or images that do not fit the rig.
SweepResult per_pixel_sweep(const Rig& rig, const std::vector<cv::Mat>& images,
                            const ViewRequest& req, int planes = 64, int window = 5);

}  // namespace lf
