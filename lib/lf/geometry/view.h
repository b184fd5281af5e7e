// View requests (Yang et al. 2002, Section 4.3: "The view request consists of
// a virtual view and focal plane. The virtual view is specified by position,
// orientation, and field-of-view, and the focal plane is specified by a plane
// equation.") plus the aperture and the tags that route fragments.
//
// All positions and planes are in rig (world) coordinates and rig units.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lf/geometry/camera.h"
#include "lf/render/quilt.h"

namespace lf {

// Focal plane pi = (n, d): points X with n . X + d = 0, as a homogeneous
// 4-vector. n = (0, 0, 0) with d != 0 is the plane at infinity (focus at
// infinity: every camera samples the direction of the viewing ray).
struct FocalPlane {
  cv::Vec3d n = {0, 0, 1};
  double d = -1.0;

  bool at_infinity() const { return n[0] == 0 && n[1] == 0 && n[2] == 0; }
  static FocalPlane infinity() { return {{0, 0, 0}, 1.0}; }
  // Plane with unit normal `normal` through point `p`.
  static FocalPlane through(const cv::Vec3d& p, const cv::Vec3d& normal);
};

// A piecewise-planar focal surface over the output image: the image is cut
// into square tiles of `tile` output pixels (tile (c, r) covers pixels
// x in [c*tile, min((c+1)*tile, width)), y likewise; the last column and row
// may be narrower) and each tile is focused on one of a few planes. Each
// camera then has one homography per plane, so a fragment is still the
// paper's fragment, cut into pieces at tile edges (lf/render/plan.h). An empty
// surface (tile == 0) means the request's single focal plane everywhere.
// Estimated from the images by lf/focus/focal_surface.h.
struct FocalSurface {
  int tile = 0;                    // tile size, output pixels (0: no surface)
  int cols = 0, rows = 0;          // ceil(width / tile), ceil(height / tile)
  std::vector<FocalPlane> planes;  // distinct planes, 1..kMaxPlanes
  std::vector<uint8_t> plane_of;   // rows * cols, row-major: index into planes
  // Two depths in a tile (a foreground object's rim, a thin structure
  // before a background): optionally a second plane per tile, rows * cols
  // indices into planes, kNone where the tile has one plane; empty when no
  // tile has two. Each camera then also sends a fragment of just those
  // tiles through the nearer of their two planes (lf/render/plan.h
  // plan_fragment's layer 1; layer 0 takes the other), and the compositor
  // chooses per pixel: the nearer layer unless the other's cameras agree
  // clearly better (lf/render/composite.h LayerCompositor). On the wire: lf/wire/wire.h.
  std::vector<uint8_t> second_of;
  static constexpr uint8_t kNone = 0xFF;
  static constexpr int kMinTile = 4, kMaxTile = 1024, kMaxPlanes = 64;

  bool empty() const { return tile == 0; }
  int plane_at(int x, int y) const { return plane_of[(y / tile) * cols + x / tile]; }
  // Whether some tile has a second plane.
  bool two_planes() const;
  // Tiles with a second plane.
  int two_plane_tiles() const;
  // Distinct planes that some tile uses (first or second).
  int planes_used() const;
};

// Aperture filter over the camera plane (Isaksen et al. 2000). The paper's
// renderer uses the tent: barycentric weights over the rig's triangulation
// (1 at a camera, 0 at its neighbours). ViewRequest::aperture_scale widens
// it: camera i's weight at camera-plane point X is its tent weight at
// C_i + (X - C_i) / scale (C_i: the camera's position on the plane), so its
// support (the triangles around it, its "star") grows by `scale` about the
// camera and overlaps its neighbours'; the compositor's renormalisation
// makes the weights a partition of unity again. Off-surface content then
// blurs over more cameras instead of doubling (a synthetic large aperture,
// Vaish et al. 2004); scale 1 is the paper's, the smallest. An eye on the
// camera plane but outside the triangulation (beyond the array, or on its
// border up to the cameras' scatter) is weighed as at the nearest point of
// the triangulation, so its view is the border cameras', not black.
//
// kUlr: Unstructured Lumigraph weights (Buehler et al. 2001) for rigs
// without a grid and for covering a lost camera: at the vertices of a grid
// of kUlrGrid-pixel cells over the output, the k = ulr_cameras cameras that
// see the pixel's focal point with the least penalty
// (1 - r) * angle + r * max(0, |F - C_i| - |F - E|) / |F - E| (radians;
// F the focal point, E the eye, C_i the camera, r = kUlrResolutionWeight)
// get w_i = 1 - penalty_i / threshold, normalised to sum 1, and the weights
// are interpolated linearly over the two triangles of each cell (as the
// paper's blending field). Tie rule: the threshold is the penalty of the
// (k+1)-th camera (not the k-th, which would give every camera 0 where the
// k nearest tie, as at the centre of a grid cell); where that ties with the
// 2nd (an eye right over a camera, whose neighbours tie), every camera
// tying with the 2nd blends and the threshold is the next larger penalty;
// with k or fewer cameras seeing the point, all of them blend (threshold
// 1.001 x the largest penalty). Weights are continuous except at such
// ties, sum to 1 at every pixel some camera sees, and every pixel seen by
// two cameras or more is blended from two or more, so a lost camera leaves
// no hole.
//
// kFourCamera: bilinear weights over the grid cell around the line's
// camera-plane point X: the mean of the tents of the rig's triangulation and
// of the same cells split along their other diagonals (each pair of
// triangles sharing its longest edge, a cell's diagonal, flipped). The mean
// is linear on the four triangles both diagonals cut a cell into, and equals
// bilinear weights over the cell's four cameras at its corners, edge
// midpoints and centre: a view at a cell's centre blends all four cameras
// where the tent blends the two of one diagonal. Triangles with no partner
// (a rig without a grid, the hull's border) keep the tent. Weights are
// evaluated at the vertices of the kUlrGrid-pixel grid and interpolated
// over its cells as kUlr's (exact for an eye on the camera plane, where
// they are constant); no scale, no ulr_cameras. Measured on in-between
// views (docs/rendering.md, "Four-camera weights").
enum class Aperture : uint8_t { kTent = 0, kUlr = 1, kFourCamera = 2 };
constexpr int kUlrGrid = 64;  // output pixels per blending-field cell
constexpr double kUlrResolutionWeight = 0.2;
constexpr int kMinUlrCameras = 2, kMaxUlrCameras = 16;

// How a camera's image is resampled into its fragment (lf/render/render.h): the
// paper's bilinear filter, or bicubic (Keys 1981, a = -0.5): sharper where
// cameras and view sample the scene alike (Chess leave-one-out at 1:1 with
// a focal surface: +0.74 dB), no help through a single plane (its double
// images dominate) and a little worse when minifying (neither prefilters);
// its warp costs about 2.2x the bilinear one.
enum class Sampling : uint8_t { kBilinear = 0, kBicubic = 1 };
constexpr double kMaxApertureScale = 16.0;
// The aperture's diameter in rig units for a scale: the tent's support
// spans two camera spacings (neighbour to neighbour), so D = 2 * spacing *
// scale (Rig::typical_spacing()); and back (never below 1, the tent).
double aperture_diameter(double scale, double spacing);
double aperture_scale_for(double diameter, double spacing);
// Full-frame-equivalent f-number of an aperture of `diameter_mm` for a view
// `width` pixels wide with focal length `fx` pixels: N = F / D with
// F = 36 mm * fx / width, the focal length of a 36 mm wide (full-frame)
// sensor with the view's field of view. Such a camera at f/N, focused where
// the view is focused, blurs a point at inverse depth q over
// fx * D * |q - q_focus| pixels (thin lens, focus distance >> F), as the
// synthetic aperture does. 0 for a diameter of 0.
double full_frame_f_number(double diameter_mm, double fx, int width);
// Millimetres per rig unit for a Rig::unit of "mm", "cm" or "m"; 0 when the
// unit is not a length (e.g. the Stanford archive's parallax unit).
double millimetres_per_unit(const std::string& unit);
// The diameter (rig units) of full-frame-equivalent f-number `f_number`
// (the inverse of full_frame_f_number), or 0 when mm_per_unit is 0.
double diameter_for_f_number(double f_number, double fx, int width, double mm_per_unit);

// The virtual camera. Intrinsics are derived from the vertical field of view
// and the size; `shift_x/shift_y` move the principal point off the image
// centre (an off-axis "lens shift", as in the rectified cameras of a light
// slab). Pixel convention as in camera.h.
struct VirtualView {
  cv::Vec3d position = {0, 0, 0};      // eye, rig coordinates
  cv::Matx33d R = cv::Matx33d::eye();  // world -> view rotation
  double vfov_deg = 60.0;              // vertical field of view, degrees
  int width = 640;                     // output size, pixels
  int height = 480;
  double shift_x = 0.0;  // principal point offset, pixels
  double shift_y = 0.0;

  double focal_px() const;  // fx = fy = (height/2) / tan(vfov/2)
  Intrinsics intrinsics() const;
  // A virtual view identical to a camera (pose and, after scaling to the
  // output size, intrinsics). Requires fx == fy within 1e-9 relative.
  static VirtualView from_camera(const Camera& cam, int width, int height);
  // Look-at constructor: eye, target, and the world "down" hint (camera y).
  static VirtualView look_at(const cv::Vec3d& eye, const cv::Vec3d& target, const cv::Vec3d& down,
                             double vfov_deg, int width, int height);
};

struct ViewRequest {
  uint32_t viewer_id = 0;  // which viewer (one output stream per viewer)
  uint64_t sequence = 0;   // request number, increasing per viewer
  VirtualView view;
  FocalPlane focal_plane;  // the single plane; with a surface, where it has none
  FocalSurface surface;    // optional per-tile focal planes (empty: focal_plane)
  Aperture aperture = Aperture::kTent;
  double aperture_scale = 1.0;  // 1..kMaxApertureScale (see Aperture); 1 with kUlr, kFourCamera
  int ulr_cameras = 4;          // k of kUlr, kMinUlrCameras..kMaxUlrCameras
  Sampling sampling = Sampling::kBilinear;
  // The instant the request is for (ns of running time on the pipeline
  // clock; in a deployment, the shared network clock and base time), or -1
  // when unknown. Set by the viewer from the request's PTS, so a camera host
  // knows it whatever the network delay: with lffragment
  // frame-select=capture-time every camera warps the frame captured at or
  // before it, all from one capture instant.
  int64_t time_ns = -1;
  // A quilt of eyes along a baseline (lf/render/quilt.h): `view` is then the
  // centre eye with the quilt frame's width and height, and each camera
  // answers every eye in one buffer. Empty: one view.
  Quilt quilt;
};

// Throws std::invalid_argument naming the field when a request cannot be
// rendered: non-finite numbers, size outside 1..16384, fov outside
// (0, 179.9] degrees, R not a rotation, an aperture scale outside
// 1..kMaxApertureScale, a focal plane with n = 0 and d = 0, or
// a surface whose tile size is outside kMinTile..kMaxTile, whose grid does
// not match the output size, with 0 or more than kMaxPlanes planes, a bad
// plane, or a tile naming a plane that is not there (a second plane must
// name another plane than the tile's first), or a quilt that
// lf::validate_quilt refuses or that has a focal surface.
void validate(const ViewRequest& req);

}  // namespace lf
