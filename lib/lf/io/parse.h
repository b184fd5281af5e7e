// Text forms of numbers and focal planes, as users type them (tool flags,
// element properties). Errors: std::invalid_argument naming the field.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"

namespace lf {

// Parses "a,b,c" into finite numbers; throws std::invalid_argument naming
// `what` and the bad token.
std::vector<double> parse_number_list(const std::string& s, const std::string& what);

// Parses "x,y,z" (exactly three finite numbers); throws std::invalid_argument
// naming `what`.
cv::Vec3d parse_point(const std::string& s, const std::string& what);

// Parses a list of indices and inclusive ranges, "0-15,20,22-23", into the
// sorted distinct indices, each checked against 0..count-1; empty: all of
// them. Throws std::invalid_argument naming `what` and the bad token.
std::vector<int> parse_index_ranges(const std::string& s, int count, const std::string& what);

// A per-camera file name from a pattern with exactly one "%d" or "%0Nd"
// (N = 1..9), e.g. "rec/cam%02d.mkv" -> "rec/cam07.mkv" for camera 7; "%%"
// is a literal '%'. The pattern is never used as a printf format. Throws
// std::invalid_argument naming `what` when there is no such field, more than
// one, or any other '%' sequence.
std::string camera_file_name(const std::string& pattern, int camera_id, const std::string& what);

// Parses a focal-plane specification: "infinity", "depth:Z" (rig units from
// the camera plane), "param:A" (light-slab focal parameter) or
// "plane:nx,ny,nz,d". Throws std::invalid_argument naming the problem.
FocalPlane parse_focal_plane(const std::string& spec, const Rig& rig);

// Where `plane` lies in front of the cameras: the distance, in rig units,
// from the centroid of the camera centres along the camera plane's normal
// (the way the cameras look) to the plane; +infinity for the plane at
// infinity or one parallel to that direction. A focal plane at a depth <= 0
// is behind (or at) the cameras: nothing any camera sees is on it, and every
// view focused there is empty.
double focal_plane_depth(const Rig& rig, const FocalPlane& plane);

}  // namespace lf
