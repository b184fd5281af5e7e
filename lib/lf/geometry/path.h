// Camera paths: keyframed virtual-camera trajectories (the model). File
// format: lf/io/path_file.h; sampling into views: lf/geometry/view_builder.h.
#pragma once

#include <opencv2/core.hpp>

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

}  // namespace lf
