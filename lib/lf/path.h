// Camera paths: keyframed virtual-camera trajectories for offline renders
// and for the lfviewrequest element.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lf/rig.h"
#include "lf/view.h"

namespace lf {

// A keyframed camera path. JSON: {"keyframes": [{"position": [x, y, z],
// "look_at": [x, y, z] (optional), "vfov": deg (optional)}, ...]}. Without
// look_at, the view at each point looks like the rig's cameras
// (view_between_cameras). Positions are interpolated with Catmull-Rom.
struct Keyframe {
  cv::Vec3d position;
  bool has_look_at = false;
  cv::Vec3d look_at;
  double vfov = 0;  // 0: derived from the cameras
};
std::vector<Keyframe> load_path(const std::string& file);
// Orbit on the camera plane around its centre: radius = fraction of the
// array's half-extent, plus an optional dolly (+-dolly rig units along the
// normal, one period per orbit).
std::vector<Keyframe> orbit_path(const Rig& rig, double fraction, double dolly, int frames);
// Samples a keyframed path at `frames` evenly spaced parameters.
std::vector<VirtualView> sample_path(const Rig& rig, const std::vector<Keyframe>& keys, int frames,
                                     int width, int height, bool closed);

}  // namespace lf
