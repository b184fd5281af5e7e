// Point-light tracking (Yang et al. 2002, 4.4.2 step 2; Svoboda et al. 2005):
// in a dark scene, the light is the one bright blob in each frame. A frame
// gives an observation only if it holds exactly one spot that is neither
// saturated over a large area nor elongated (a motion streak); its centre is
// the background-subtracted intensity centroid (sub-pixel). Observations of
// all cameras are matched by frame index (the capture instant: the cameras
// share a capture schedule, lfcamsrc / tools/lf-launch).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "calib/selfcal.h"

namespace lf::calib {

struct SpotOptions {
  double threshold = 0;       // grey level; 0: half the frame's maximum, at least min_peak
  double min_peak = 40;       // a frame darker than this has no spot
  int min_area = 2;           // pixels; smaller blobs are noise
  int max_area = 2000;        // larger: not a point light
  double max_elongation = 3;  // ratio of the blob's principal axes; above: a streak
  int saturated_level = 250;
  int max_saturated = 40;  // saturated pixels allowed in the spot
};

enum class SpotStatus { kFound, kNone, kSeveral, kStreak };

struct Spot {
  SpotStatus status = SpotStatus::kNone;
  cv::Point2d centre;  // pixels, (0, 0) = centre of the top-left pixel
  int area = 0;
  std::string why;  // for rejected frames
};

// One frame (8-bit grey, BGR or BGRA).
Spot find_spot(const cv::Mat& frame, const SpotOptions& options = {});

struct TrackStats {
  std::string source;
  int frames = 0, found = 0, none = 0, several = 0, streak = 0;
  cv::Size image_size;
};

// Frame sources: a folder of images (sorted by name), a video file (OpenCV's
// VideoCapture), or "gst:PIPELINE", a GStreamer source description (a live
// camera, e.g. "gst:v4l2src device=/dev/video0 num-buffers=300"; converted
// to BGR and read through an appsink). Frame k of every source must be the
// same capture instant: live cameras need a common capture schedule
// (hardware trigger, or lfcamsrc on a shared clock). Observations for camera k come from
// sources[k], point index = frame index. Throws std::runtime_error naming a source that cannot be
// read or whose frame size changes.
std::vector<PointObservation> track_point_light(const std::vector<std::string>& sources,
                                                std::vector<TrackStats>* stats = nullptr,
                                                const SpotOptions& options = {},
                                                void (*progress)(int done, int total) = nullptr);

// A simulated frame of the point light seen by `cam` (for tests and the
// end-to-end check): a Gaussian spot of `sigma_px` and `peak` grey levels at
// the light's (distorted) projection, on a dark background with Gaussian
// noise of `noise` levels; 8-bit grey, cam.width x cam.height. All dark when
// the light is behind the camera.
cv::Mat render_point_light(const Camera& cam, const cv::Vec3d& light, double sigma_px = 1.2,
                           double peak = 200, double noise = 2, uint64_t seed = 1);

}  // namespace lf::calib
