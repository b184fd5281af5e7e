// Rig files: a Rig (lf/geometry/rig.h) as versioned JSON.
#pragma once

#include <string>

#include "lf/geometry/rig.h"

namespace lf {

// Rig file (JSON text, "format": "lightfield-gst-rig", "version": 1), read and
// written with nlohmann::json. Image paths are stored relative to the file's
// folder when possible. Throws std::runtime_error with the file name and the
// field on any error; the rig returned is finalized. A file over 16 MiB is
// refused before it is read, one of more than 16384 cameras before a camera
// is built, and every number must be finite and plausible (lf::Rig::finalize:
// image sides 2..65535, 0 < fx, fy <= 10^4 image sides, |cx|, |cy| <= 10
// sides, |k1|, |k2| <= 100, |t| <= 10^9 rig units, R a rotation).
Rig load_rig(const std::string& path);
void save_rig(const Rig& rig, const std::string& path);
// (De)serialization to a JSON string (image paths kept as they are).
std::string rig_to_json(const Rig& rig);
Rig rig_from_json(const std::string& text, const std::string& origin = "<string>");

}  // namespace lf
