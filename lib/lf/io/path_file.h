// Camera path files (JSON): {"keyframes": [{"position": [x, y, z],
// "look_at": [x, y, z] (optional), "vfov": deg (optional)}, ...]}, positions
// in rig units, at least two keyframes. Throws std::runtime_error naming the
// file and the field.
#pragma once

#include <string>
#include <vector>

#include "lf/geometry/path.h"

namespace lf {

std::vector<Keyframe> load_path(const std::string& file);

}  // namespace lf
