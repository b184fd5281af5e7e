// Camera images read without OpenCV's imgcodecs: PNG through libpng, JPEG
// through TurboJPEG. Debian's libopencv_imgcodecs pulls in GDAL and about
// 140 more libraries; loading them took 100-120 ms of every start of a
// process that links it (the GStreamer plugin, lf-rig), which a restarted
// camera host spent before it could capture (issue 15: rejoin within 1 s).
//
// The pixels are those of cv::imread(path, cv::IMREAD_COLOR) for the same
// file (tested on the datasets' PNG and JPEG images, on grey, 16-bit and
// alpha PNGs and a grey JPEG), with one exception: a JPEG's EXIF orientation
// is not applied (a camera's calibration is in its sensor's orientation).
// A JPEG cut short or with corrupt data is an error (libjpeg only warns and
// fills the rest with grey; cv::imread returns that picture).
// PNG as OpenCV 4.6 reads it: 16-bit samples keep their high byte, alpha
// and transparency are dropped (not composited), grey is replicated.
#pragma once

#include <opencv2/core.hpp>
#include <string>

namespace lf {

// The image at `path` as 8-bit BGR (CV_8UC3, rows top-down). Throws
// std::runtime_error naming the file: missing, unreadable, not PNG or JPEG
// (by content, not name), damaged, or larger than 32768 x 32768.
cv::Mat read_image(const std::string& path);

// The size of the image at `path` from its header alone (PNG IHDR, JPEG
// SOF); the same errors.
cv::Size read_image_size(const std::string& path);

// Whether the file at `path` begins as a PNG or a JPEG does (false when it
// cannot be read): what read_image reads.
bool is_still_image(const std::string& path);

// Throws std::runtime_error naming `path` unless an image of size `image`
// becomes a camera's width x height by one uniform resize (the same size,
// or a rig scaled by lf::scale_rig, within a pixel of rounding): a still of
// another size or shape is some other camera's, and is never stretched.
void check_image_fits(const std::string& path, cv::Size image, int width, int height);

}  // namespace lf
