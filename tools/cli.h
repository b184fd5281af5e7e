// Helpers shared by the command-line tools (argument parsing, progress
// output, focal-plane specifications, camera paths).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "lf/renderer.h"

namespace cli {

// --key value / --flag parsing. Unknown options are an error.
class Args {
 public:
  Args(int argc, char** argv, const std::vector<std::string>& flags_with_value,
       const std::vector<std::string>& bare_flags);
  bool has(const std::string& k) const { return values_.count(k) > 0; }
  std::string get(const std::string& k, const std::string& def = "") const;
  double number(const std::string& k, double def) const;
  int integer(const std::string& k, int def) const;
  std::vector<double> numbers(const std::string& k, size_t n_min, size_t n_max) const;

 private:
  std::map<std::string, std::string> values_;
};

std::vector<double> parse_numbers(const std::string& s, const std::string& what);
void parse_size(const std::string& s, int& w, int& h);

// Prints "label [#####    ] k/n" on stderr (a single updating line on a
// terminal, a few lines otherwise).
void progress(const std::string& label, int done, int total);

// Focal-plane specification: "auto", "infinity", "depth:Z", "param:A"
// (light-slab focal parameter), "plane:nx,ny,nz,d".
struct FocalSpec {
  enum Kind { kAuto, kPlane } kind = kAuto;
  lf::FocalPlane plane;
  std::string text;
};
FocalSpec parse_focal(const std::string& s, const lf::Rig& rig);

// A keyframed camera path. JSON: {"keyframes": [{"position": [x, y, z],
// "look_at": [x, y, z] (optional), "vfov": deg (optional)}, ...]}. Without
// look_at, the view at each point looks like the rig's cameras
// (lf::view_between_cameras). Positions are interpolated with Catmull-Rom.
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
std::vector<Keyframe> orbit_path(const lf::Rig& rig, double fraction, double dolly, int frames);
// Samples a keyframed path at `frames` evenly spaced parameters.
std::vector<lf::VirtualView> sample_path(const lf::Rig& rig, const std::vector<Keyframe>& keys,
                                         int frames, int width, int height, bool closed);

}  // namespace cli
