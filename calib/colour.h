// Colour calibration of a camera array (Yang et al. 2002, 4.4.3; Joshi et
// al. 2005; Nanda & Cutler 2001): every camera sees the same colour samples
// (patches of a shared target, or corresponding points of the common scene);
// each camera gets the correction that maps its colours onto the reference
// (the array's per-sample median, or a given reference): a per-channel gain
// and offset, or, where the data supports it, an affine 3x4 (channel
// crosstalk). Cameras whose correction is implausible (a gain far from 1, a
// large offset, a channel without range, or a poor fit: the paper's cameras
// with defective colour controls) are flagged. Differences are measured in
// CIE deltaE2000 (Sharma, Wu, Dalal 2005) of sRGB colours (D65).
//
// Colours are 8-bit RGB levels as doubles; corrections map camera RGB to
// corrected RGB: c' = A c + b, stored as lf::Camera::colour (row-major [A | b]).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"

namespace lf::calib {

// sRGB (8-bit levels, D65) -> CIE L*a*b*.
cv::Vec3d srgb_to_lab(const cv::Vec3d& rgb);
// CIEDE2000 colour difference.
double delta_e2000(const cv::Vec3d& lab1, const cv::Vec3d& lab2);

enum class ColourModel { kGainOffset, kAffine };

struct CameraColour {
  ColourModel model = ColourModel::kGainOffset;
  cv::Matx34d correction = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  double delta_e_before = 0, delta_e_after = 0;  // mean over samples, against the reference
  bool defective = false;
  std::string why;  // why it is flagged, or which model was chosen and why
};

struct ColourOptions {
  double min_gain = 0.5, max_gain = 2.0;  // outside: defective controls
  double max_offset = 40;                 // levels
  double max_delta_e = 3.0;               // after correction; above: defective
  double min_range = 10;                  // a channel's sample spread (levels); below: dead
  double affine_gain = 0.2;               // affine kept if it lowers the held-out
                                          // (leave-one-out) mean deltaE by this fraction
};

struct ArrayColour {
  std::vector<CameraColour> cameras;
  std::vector<cv::Vec3d> reference;                        // per sample
  double mean_delta_e_before = 0, mean_delta_e_after = 0;  // over good cameras
  std::string report;
};

// samples[camera][k]: camera's RGB of sample k (same k = same target patch
// or scene point in every camera). reference: per-sample RGB; empty: the
// per-sample median over the cameras. Throws std::invalid_argument if the
// cameras have different sample counts or fewer than 8 samples.
ArrayColour calibrate_colours(const std::vector<std::vector<cv::Vec3d>>& samples,
                              const std::vector<cv::Vec3d>& reference = {},
                              const ColourOptions& options = {});

// Colour samples from one image per camera of a shared flat target or of
// the common scene (lying near `plane`; the plane at infinity for a distant
// scene): points on a grid of `grid` x `grid` over the reference camera's
// image, kept where its 5x5 neighbourhood is smooth (so small registration
// errors do not mix colours), are mapped into every camera through the
// plane, and the 5x5 mean colour there is the sample. Points that leave any
// camera's image are skipped. images: CV_8UC3/4 in RGB(A) order, one per
// rig camera. Returns samples[camera][k] for calibrate_colours.
std::vector<std::vector<cv::Vec3d>> colour_samples_from_images(const Rig& rig,
                                                               const std::vector<cv::Mat>& images,
                                                               const FocalPlane& plane,
                                                               int reference = 0, int grid = 24);

}  // namespace lf::calib
