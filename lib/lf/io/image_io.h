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
#include <utility>
#include <vector>

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

// A camera's image: read_image(path), checked by check_image_fits, resized
// to width x height (INTER_AREA) when it differs, as RGBA (CV_8UC4). Throws
// as they do.
cv::Mat read_camera_image(const std::string& path, int width, int height);

// The frames of a camera input that is a PNG or JPEG still, or a numbered
// sequence of them (`location` a pattern with one %d, lf::camera_file_name),
// read by read_camera_image, so that a damaged, truncated or wrong-sized
// frame is an error naming its file (GStreamer's parsers drop such a frame
// silently, and jpegdec greys out the rest of a truncated one).
class StillSequence {
 public:
  StillSequence(std::string location, int width, int height, bool loop, bool skip_bad_frames)
      : location_(std::move(location)),
        width_(width),
        height_(height),
        loop_(loop),
        skip_bad_(skip_bad_frames) {}
  bool is_sequence() const { return location_.find('%') != std::string::npos; }
  // The file of frame k (the still itself when it is no sequence), and its
  // name in messages (with the frame number for a sequence).
  std::string path(int64_t k) const;
  std::string name(int64_t k) const;
  struct Next {
    enum class What {
      kFrame,        // a new frame in *rgba
      kSame,         // a still, looped: *rgba unchanged
      kEnd,          // the input ended (no loop)
      kMissing,      // the first frame's file is missing or unreadable
      kUndecodable,  // a frame does not decode (and is not to be skipped), or none does
    } what = What::kFrame;
    std::string error;                 // kMissing, kUndecodable: what and why
    std::vector<std::string> skipped;  // skip_bad_frames: the frames skipped, and why
  };
  // The next frame; at the end kEnd, or the first again with loop. A frame
  // that does not decode is kUndecodable, or with skip_bad_frames (in a
  // sequence) skipped and the next one taken.
  Next next(cv::Mat* rgba);

 private:
  std::string location_;
  int width_, height_;
  bool loop_, skip_bad_;
  int64_t index_ = 0;  // the next frame (a still: 0, then the end)
};

}  // namespace lf
