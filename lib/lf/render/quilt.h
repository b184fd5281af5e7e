// Quilts: many views of one scene along a horizontal baseline, tiled in one
// frame, as light-field (lenticular) displays take them. The layout is the
// one the Looking Glass tools read: `views` tiles of equal size in `cols` x
// `rows`, the first view (the leftmost eye) at the bottom-left, then left
// to right, then upward; a file's name says the layout with the suffix
// "_qs<cols>x<rows>a<aspect>" (aspect: a view's width / height).
//
// A quilt request (lf/geometry/view.h ViewRequest::quilt) asks every camera for all
// the quilt's eyes at once: each camera answers with one buffer holding its
// fragment of every eye it sees (lf/wire/wire.h), each fragment a rectangle of
// the quilt frame, so one request round serves every view.
//
// Eyes: the request's view is the centre eye, except that its width and
// height are the quilt's. Eye i (0..views-1) sits at
//   E_i = E + R^T (b * (i / (views - 1) - 1/2), 0, 0)
// (E the request's eye, R its world->view rotation, b the baseline in rig
// units: the first eye is the leftmost, -b/2 along the view's x axis), has
// the tile's size and the request's vertical field of view, and its
// principal point is shifted so that every eye sees the point of the focal
// plane on the centre eye's optical axis, at distance D, at the same pixel:
// shift_x_i = shift_x + f * x_i / D (f the tile view's focal length in
// pixels, x_i the eye's offset). This is the sheared ("off-axis") frustum
// of a light-field display's cameras: what lies on the focal plane appears
// on the display's surface, nearer things in front of it. A focal plane at
// infinity, or not in front of the eye, gives parallel eyes (no shift).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace lf {

struct ViewRequest;
class Rig;

struct Quilt {
  static constexpr int kMaxViews = 128;  // the most eyes a quilt request carries
  static constexpr int kMaxTiles = 255;  // cols * rows
  int views = 0;                         // 0: not a quilt; 2..kMaxViews
  int cols = 0, rows = 0;                // tiles; views <= cols * rows <= kMaxTiles
  double baseline = 0;                   // rig units, first eye to last, >= 0

  bool empty() const { return views == 0; }
};

// The tile of view i in a `width` x `height` quilt frame (width a multiple
// of cols, height of rows): its top-left pixel and size, row 0 at the
// bottom of the frame.
cv::Rect quilt_tile(const Quilt& q, int width, int height, int i);

// Eye i of a quilt request (see above): a request without a quilt, of the
// tile's size, the request's viewer, sequence, focal plane, aperture,
// sampling and time. Throws std::invalid_argument for i out of range or a
// request that is not a quilt.
ViewRequest quilt_eye(const ViewRequest& req, int i);

// The distance along the centre eye's optical axis to its focal plane
// (rig units), or +infinity (a plane at infinity, parallel to the axis, or
// behind the eye).
double convergence_distance(const ViewRequest& req);

// The baseline that gives a view cone of `cone_deg` degrees (the angle the
// first and last eyes subtend at the convergence point): 2 D tan(cone/2).
// 0 when D is infinite.
double baseline_for_cone(double distance, double cone_deg);

// The rig's width along `axis` (a unit vector): the spread of its camera
// centres' projections on it, rig units (the parallax a quilt's baseline
// can show without eyes beyond the array).
double array_extent(const Rig& rig, const cv::Vec3d& axis);

// "_qs8x6a0.75": the suffix of a quilt file's name (before the extension)
// that the display tools read; the aspect with at most 4 decimals.
std::string quilt_suffix(const Quilt& q, int width, int height);

// Throws std::invalid_argument naming the field: views outside
// 2..kMaxViews, more views than tiles, tiles over kMaxTiles, a size that
// is not a whole number of tiles, a baseline that is negative or not
// finite.
void validate_quilt(const Quilt& q, int width, int height);

}  // namespace lf
