// A rig: the cameras of an array, their fixed topology and the triangulation
// of the camera surface used by the paper's renderer (Yang et al. 2002,
// Section 4.1: "we triangulate this grid to arrive at a fixed topology").
//
// Camera plane. Weights (the aperture) are defined on the camera plane: the
// least-squares plane through the camera centres, oriented so that its normal
// points the way the cameras look. 2D camera-plane coordinates (s, t) are
// measured from the centroid of the centres along the unit axes `u` and `v`
// (u follows the cameras' mean x axis, v = normal x u follows their y axis),
// in rig units. Each camera centre is projected onto the plane; cameras need
// not be exactly coplanar (their true 3D poses are used for texture mapping).
//
// Aperture simplices. The triangulation is stored as simplices over the
// camera plane: triangles for 2D arrays, segments for a linear (1 x N) array,
// a single point for a one-camera rig. Each vertex of a simplex carries a
// linear form e(s, t) = a s + b t + c, positive inside, that is proportional
// to the vertex's barycentric weight; the forms of one simplex sum to a
// positive constant. Forms are stored once per facet (edge, or end point of a
// segment) and referenced with a sign, so that neighbouring simplices evaluate
// bit-identical, opposite values on their shared facet (watertight coverage).
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "lf/geometry/camera.h"

namespace lf {

// Rows x cols topology; cells hold an index into Rig::cameras or -1 (empty).
struct Grid {
  int rows = 0;
  int cols = 0;
  std::vector<int> cells;  // row-major, size rows*cols

  bool empty() const { return rows == 0 || cols == 0; }
  int at(int r, int c) const { return cells[static_cast<size_t>(r) * cols + c]; }
};

struct CameraPlane {
  cv::Vec3d origin;  // centroid of the camera centres
  cv::Vec3d u, v;    // unit in-plane axes (s and t directions)
  cv::Vec3d normal;  // unit normal, u x v, pointing the way the cameras look

  cv::Vec2d to_plane(const cv::Vec3d& X) const {
    const cv::Vec3d d = X - origin;
    return {d.dot(u), d.dot(v)};
  }
  double signed_distance(const cv::Vec3d& X) const { return (X - origin).dot(normal); }
};

// Linear form a*s + b*t + c over the camera plane, zero on its facet. It is
// evaluated as a (s - s0) + b (t - t0) from a stored point (s0, t0) of the
// facet, which is exactly zero at both end points of an edge whatever the
// rounding (so the tie rule sees exact zeros at vertices).
struct Form2 {
  double a = 0, b = 0, c = 0;
  double s0 = 0, t0 = 0;
  double operator()(const cv::Vec2d& p) const { return a * (p[0] - s0) + b * (p[1] - t0); }
};

struct Simplex {
  int size = 0;                          // 1 (point), 2 (segment) or 3 (triangle)
  std::array<int, 3> cams{-1, -1, -1};   // indices into Rig::cameras
  std::array<int, 3> facet{-1, -1, -1};  // per vertex: index into Rig::facets (-1 for a point)
  std::array<int, 3> sign{0, 0, 0};      // per vertex: +1 or -1 applied to the facet form
};

class Rig {
 public:
  std::string name;
  std::string unit = "unit";  // name of the length unit of positions, e.g. "m", "mm"
  std::vector<Camera> cameras;
  Grid grid;  // optional (empty for unstructured rigs)
  // Triangulation as triples of camera ids (not indices); filled by
  // finalize() when empty. Pairs / singletons are implied for 1D / 1-camera rigs.
  std::vector<std::array<int, 3>> triangles;

  // Light-slab focal parameter (optional): rectified parallel rigs such as the
  // Stanford archive describe a focal plane by `a`, the image shift in pixels
  // per rig unit of camera displacement. The plane parallel to the camera
  // plane at depth z (along the normal, from the plane) has
  // a = a_infinity - f_px / z, i.e. z = f_px / (a_infinity - a).
  // Notes from importers about input they had to adapt (e.g. a duplicate
  // viewpoint dropped); tools print them.
  std::vector<std::string> warnings;

  bool has_focal_param = false;
  double focal_param_f_px = 0.0;
  double focal_param_infinity = 0.0;

  // Validates the rig and computes the camera plane, the triangulation (if not
  // given) and the aperture simplices. Throws std::invalid_argument naming the
  // offending camera or field on: no cameras, duplicate ids, bad image size or
  // intrinsics (not finite, or implausible: fx, fy over 10^4 image sides,
  // cx, cy over 10 sides away, |k1|, |k2| over 100), non-rotation R, t not
  // finite or over 10^9 units, coincident camera centres, triangles naming
  // unknown cameras, or a triangulation that folds over on the camera plane.
  void finalize();

  // Derived by finalize().
  const CameraPlane& plane() const { return plane_; }
  const std::vector<cv::Vec2d>& plane_positions() const { return plane_pos_; }
  const std::vector<Simplex>& simplices() const { return simplices_; }
  const std::vector<Form2>& facets() const { return facets_; }
  int dimension() const { return dimension_; }  // 0, 1 or 2
  int index_of(int camera_id) const;            // -1 if absent
  // Index of a camera named by its id (camera_id >= 0), or else by its grid
  // cell (row, col >= 0). Throws std::invalid_argument saying why there is
  // no such camera.
  int camera_index(int camera_id, int row, int col) const;
  // Median distance from each camera to its nearest neighbour on the plane.
  double typical_spacing() const { return spacing_; }

  // A copy without the cameras whose indices are listed (triangulation is
  // recomputed from the grid topology: holes are filled).
  Rig without(const std::vector<int>& camera_indices) const;
  // A copy keeping only the listed camera indices (grid cropped to them).
  Rig subset(const std::vector<int>& camera_indices) const;

 private:
  void compute_plane();
  void triangulate();
  void build_simplices();
  CameraPlane plane_;
  std::vector<cv::Vec2d> plane_pos_;
  std::vector<Simplex> simplices_;
  std::vector<Form2> facets_;
  int dimension_ = 0;
  double spacing_ = 0.0;
};

}  // namespace lf
