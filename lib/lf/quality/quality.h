// Image quality against ground truth (leave-one-out evaluation): the image a
// real camera shows when treated as a virtual view, PSNR (dB) and SSIM.
#pragma once

#include <opencv2/core.hpp>

#include "lf/geometry/camera.h"

namespace lf {

// The image a camera would show in VirtualView::from_camera(cam, width,
// height): resized (INTER_AREA) so its height fits, then cropped or padded
// (black) about the centre. Used as ground truth in leave-one-out tests.
// Throws if the horizontal crop is not a whole number of pixels.
cv::Mat camera_view_image(const Camera& cam, const cv::Mat& image, int width, int height);

// The part of that frame which camera_view_image() fills from the camera's
// image: all of it where the image is cropped, its centre columns where the
// image is padded (e.g. a square camera in a 4:3 view). Metrics against the
// image belong there: beyond it the truth is padding, not the scene, and a
// render that shows the scene there would count as wrong. Same checks.
cv::Rect camera_view_rect(const Camera& cam, int width, int height);

// A camera with fx != fy (e.g. Middlebury's) as one with square pixels, for
// VirtualView::from_camera: *square gets fx = fy, and the image is resampled
// to it (x' = cx + (x - cx) fy / fx, Lanczos; the principal point, the rows
// and the size stay). Undistorted cameras only (std::invalid_argument).
cv::Mat square_pixel_image(const Camera& cam, const cv::Mat& image, Camera* square);

// Quality metrics on the colour channels of two same-size 8-bit images, with
// `border` pixels cut from every side.
double psnr(const cv::Mat& a, const cv::Mat& b, int border = 0);
double ssim(const cv::Mat& a, const cv::Mat& b, int border = 0);

}  // namespace lf
