// Whole-view rendering on one machine: plan and render every camera's
// fragment and composite them (the paper's finite-viewpoints pipeline,
// Section 3.2, run in-process), plus focal-plane helpers and auto-focus.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lf/fragment.h"
#include "lf/plan.h"
#include "lf/rig.h"
#include "lf/view.h"

namespace lf {

struct RenderStats {
  size_t fragment_pixels = 0;  // pixels carried by all fragments
  int contributing = 0;        // cameras with a non-empty fragment
  double plan_ms = 0, render_ms = 0, composite_ms = 0;
};

// Renders a request. `images[i]` is camera i's CV_8UC4 image. `threads` > 1
// renders fragments of different cameras in parallel (OpenCV's pool).
// Returns CV_8UC4.
cv::Mat render_view(const Rig& rig, const std::vector<cv::Mat>& images, const ViewRequest& req,
                    RenderStats* stats = nullptr, int threads = 1);

// Plane parallel to the camera plane at depth `z` (rig units, along the
// plane normal from the plane's origin); z = inf gives the plane at infinity.
FocalPlane plane_at_depth(const Rig& rig, double z);
// Plane at inverse depth q = 1/z (q = 0: infinity).
FocalPlane plane_at_inverse_depth(const Rig& rig, double q);
// Light-slab focal parameter a (see Rig::has_focal_param). Throws if the rig
// has no such parameterisation.
FocalPlane plane_from_focal_param(const Rig& rig, double a);
double focal_param_from_inverse_depth(const Rig& rig, double q);

// Parses "a,b,c" into finite numbers; throws std::invalid_argument naming
// `what` and the bad token.
std::vector<double> parse_number_list(const std::string& s, const std::string& what);

// Parses a focal-plane specification: "infinity", "depth:Z" (rig units from
// the camera plane), "param:A" (light-slab focal parameter) or
// "plane:nx,ny,nz,d". Throws std::invalid_argument naming the problem.
FocalPlane parse_focal_plane(const std::string& spec, const Rig& rig);

// A virtual view at world position `eye` on (or near) the camera plane,
// looking like the rig's cameras: orientation of the nearest camera,
// intrinsics (focal length, principal point) interpolated barycentrically
// from the cameras of the simplex under the eye, then scaled to the output
// size (height fits; width cropped/padded about the centre).
VirtualView view_between_cameras(const Rig& rig, const cv::Vec3d& eye, int width, int height);

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
// Reusable downsampled copies of the rig and images for repeated auto-focus.
class AutofocusContext {
 public:
  AutofocusContext(const Rig& rig, const std::vector<cv::Mat>& images, AutofocusOptions opt = {});
  AutofocusResult run(const ViewRequest& req) const;

 private:
  double sweep_cost(const ViewRequest& req, int width, double q, int level) const;
  const Rig* rig_;
  AutofocusOptions opt_;
  std::vector<Rig> rigs_;                   // per pyramid level
  std::vector<std::vector<cv::Mat>> gray_;  // float grey images per level
};

// The image a camera would show in VirtualView::from_camera(cam, width,
// height): resized (INTER_AREA) so its height fits, then cropped or padded
// (black) about the centre. Used as ground truth in leave-one-out tests.
// Throws if the horizontal crop is not a whole number of pixels.
cv::Mat camera_view_image(const Camera& cam, const cv::Mat& image, int width, int height);

// Quality metrics on the colour channels of two same-size 8-bit images, with
// `border` pixels cut from every side.
double psnr(const cv::Mat& a, const cv::Mat& b, int border = 0);
double ssim(const cv::Mat& a, const cv::Mat& b, int border = 0);

}  // namespace lf
