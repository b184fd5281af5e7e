// Focal planes of a rig and auto-focus (Yang et al. 2002, Section 4.3: the
// focal plane of a view request). Planes parallel to the camera plane are
// addressed by depth z or inverse depth q = 1/z (rig units, along the camera
// plane's normal from its origin; lf/geometry/rig.h), or for light slabs by the
// archive's focal parameter a. Auto-focus picks a plane from the images alone.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"

namespace lf {

// Plane parallel to the camera plane at depth `z` (rig units, along the
// plane normal from the plane's origin); z = inf gives the plane at infinity.
FocalPlane plane_at_depth(const Rig& rig, double z);
// Plane at inverse depth q = 1/z (q = 0: infinity).
FocalPlane plane_at_inverse_depth(const Rig& rig, double q);
// Light-slab focal parameter a (see Rig::has_focal_param). Throws if the rig
// has no such parameterisation.
FocalPlane plane_from_focal_param(const Rig& rig, double a);
double focal_param_from_inverse_depth(const Rig& rig, double q);
// Inverse depth of a focal plane along the camera-plane normal: 0 for the
// plane at infinity, for a plane through the camera-plane origin or parallel
// to the normal, and for planes behind the camera plane (clamped).
double inverse_depth_of(const Rig& rig, const FocalPlane& p);

// Focal-plane choice from the images alone (photo-consistency). For each
// candidate plane parallel to the camera plane, the cameras that the tent
// aperture blends at each output pixel are warped into the view at low
// resolution; the cost is the aperture-weighted colour variance among them,
// truncated (occlusions), averaged over the view. A coarse sweep over inverse
// depth covers parallax 0 .. max_parallax_px between neighbouring cameras,
// then a finer sweep around the minimum and a parabolic fit.
struct AutofocusOptions {
  double max_parallax_px = 24.0;  // at full camera resolution, between neighbours
  int coarse_steps = 48;
  int fine_steps = 16;
  int coarse_width = 160;  // analysis width of the coarse sweep (pixels)
  int fine_width = 320;
  double truncate = 25.0;  // per-pixel colour standard deviation cap (8-bit levels)
};
struct AutofocusResult {
  FocalPlane plane;
  double inverse_depth = 0;      // 1 / z, rig units^-1
  std::vector<cv::Vec2d> curve;  // (inverse depth, cost) of every evaluated plane
};
// Photo-consistency of the plane at inverse depth `q` at every pixel of
// `req` (at req.view's size): the cameras that the tent aperture blends at
// each output pixel are sampled (bilinear) from `gray` (CV_32F, one per rig
// camera, at the rig's sizes); the cost is their aperture-weighted colour
// variance, truncated at truncate^2 (occlusions), or -1 where less than 0.9
// of the aperture sees the point. `cost` becomes CV_32F of the view's size.
// `plans`, where given, keeps the cameras' fragment plans between calls
// over different planes of the same rig, request and images (a sweep): a
// camera is planned once and re-aimed at each plane where its pixels do not
// depend on the plane (lf/render/plan.h plan_is_plane_free, aim_plan); the
// costs are the same as without it. `kernel` (lf/render/render.h): the
// AVX2 pixel loop where kAvx2 or kAvx512, the scalar one otherwise; all give
// identical costs. Throws std::invalid_argument for a kernel this CPU or
// build lacks, or grey images that are not one CV_32F image of its size
// per camera.
struct ConsistencyPlans {
  std::vector<FragmentPlan> plans;  // per camera
  std::vector<bool> reusable;       // plans[i] was made where plan_is_plane_free
};
void photo_consistency(const Rig& rig, const std::vector<cv::Mat>& gray, const ViewRequest& req,
                       double q, double truncate, cv::Mat& cost, ConsistencyPlans* plans = nullptr,
                       Kernel kernel = Kernel::kBest);

// A copy of the rig scaled so that its median image width is about
// 1.5 x `width`, with its images grey (CV_32F) at that size: what an
// analysis at `width` output pixels samples.
struct AnalysisImages {
  Rig rig;
  std::vector<cv::Mat> gray;
  int width = 0;  // the analysis width asked for
};
AnalysisImages analysis_images(const Rig& rig, const std::vector<cv::Mat>& images, int width);

// Index of the smallest cost, refined by the parabola through it and its two
// neighbours (fractional, within half a step; a minimum at either end is not
// refined). `cost` must not be empty.
double refined_minimum(const std::vector<double>& cost);

// The request at `width` output pixels (same field of view and lens shift).
ViewRequest scaled_request(const ViewRequest& req, int width);

// Reusable downsampled copies of the rig and images for repeated auto-focus.
class AutofocusContext {
 public:
  AutofocusContext(const Rig& rig, const std::vector<cv::Mat>& images, AutofocusOptions opt = {});
  AutofocusResult run(const ViewRequest& req) const;

 private:
  double sweep_cost(const ViewRequest& req, int width, double q, int level,
                    ConsistencyPlans* plans = nullptr) const;
  const Rig* rig_;
  AutofocusOptions opt_;
  std::vector<AnalysisImages> levels_;
};

}  // namespace lf
