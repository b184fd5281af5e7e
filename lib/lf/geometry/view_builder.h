// Views from what a user sets (the lfviewrequest element's properties and the
// lf-render tool's flags build views through this one place): a fixed view
// that looks like the rig's cameras, a look-at view, a keyframed camera path
// or an orbit over the camera plane. Positions in rig units and the rig's
// world frame (lf/geometry/rig.h); orientations world -> view (lf/geometry/view.h).
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lf/geometry/path.h"
#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"

namespace lf {

// A virtual view at world position `eye` on (or near) the camera plane,
// looking like the rig's cameras: orientation of the nearest camera,
// intrinsics (focal length, principal point) interpolated barycentrically
// from the cameras of the simplex under the eye, then scaled to the output
// size (height fits; width cropped/padded about the centre).
VirtualView view_between_cameras(const Rig& rig, const cv::Vec3d& eye, int width, int height);

// The point of the camera plane above world (x, y): the plane's equation
// solved for z. Throws std::invalid_argument when the plane is vertical
// (contains the z direction), where (x, y) does not fix a point.
cv::Vec3d point_on_camera_plane(const Rig& rig, double x, double y);

// Orbit on the camera plane around its centre: radius = fraction of the
// array's half-extent, plus an optional dolly (+-dolly rig units along the
// normal, one period per orbit). `frames` keyframes, evenly spaced.
std::vector<Keyframe> orbit_path(const Rig& rig, double fraction, double dolly, int frames);
// Samples a keyframed path at `frames` evenly spaced parameters (Catmull-Rom
// through the positions; closed: the last keyframe joins the first).
std::vector<VirtualView> sample_path(const Rig& rig, const std::vector<Keyframe>& keys, int frames,
                                     int width, int height, bool closed);

// An eye offset in camera-plane coordinates (lf/geometry/rig.h): s along the plane's
// u axis, t along v, w along its normal (the way the cameras look), rig
// units. The world vector s u + t v + w n.
cv::Vec3d camera_plane_offset(const Rig& rig, double s, double t, double w);
// `st` (camera-plane coordinates, rig units) if it lies on one of the rig's
// triangles, else the nearest point of the nearest triangle moved 1e-3
// camera spacing towards that triangle's centroid: an eye there lies over the
// array, so every output ray of a view on the camera plane meets a camera
// simplex (a view steered off the array would be black). The union of the
// triangles, not the convex hull: on a real rig the border cameras are not
// collinear and the hull reaches beyond every triangle. Linear arrays: the
// segment; one camera: the camera.
cv::Vec2d clamp_to_array(const Rig& rig, const cv::Vec2d& st);

// What a user sets. Precedence: a path file, then an orbit (> 0), then a
// fixed view at `position`.
struct ViewSettings {
  int width = 640, height = 480;      // output size, pixels
  std::optional<cv::Vec3d> position;  // fixed eye (default: the camera plane's origin)
  std::optional<cv::Vec3d> look_at;   // fixed target (default: look like the cameras)
  double vfov_deg = 0;                // 0: from the cameras, or 50 with look_at
  std::string path_file;              // keyframed camera path (lf/io/path_file.h)
  double orbit = 0;                   // orbit radius, fraction of the half extent (0: off)
  double dolly = 0;                   // with orbit, rig units along the normal
  int path_frames = 120;              // views per pass over a path or orbit
};

struct ViewSequence {
  std::vector<VirtualView> views;  // one per path frame (one for a fixed view)
  // A fixed view that looks like the cameras: when its eye moves, the view
  // is derived again at the new position (view_between_cameras) instead of
  // being translated, so its intrinsics follow the cameras under the eye.
  bool follows_cameras = false;
  // View k of the sequence (cycling), its eye moved by `offset` (rig units).
  VirtualView at(uint64_t k, const Rig& rig, const cv::Vec3d& offset = {0, 0, 0}) const;
};

// Builds the views. Throws std::invalid_argument (bad settings, or a first
// view that lf::validate rejects) or std::runtime_error (unreadable path).
ViewSequence build_views(const Rig& rig, const ViewSettings& s);

}  // namespace lf
