#include "lf/render/quilt.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"

namespace lf {

void validate_quilt(const Quilt& q, int width, int height) {
  auto bad = [](const std::string& what) { throw std::invalid_argument("quilt: " + what); };
  if (q.views < 2 || q.views > Quilt::kMaxViews)
    bad(std::to_string(q.views) + " views (2.." + std::to_string(Quilt::kMaxViews) + ")");
  if (q.cols < 1 || q.rows < 1 || q.cols * q.rows > Quilt::kMaxTiles)
    bad(std::to_string(q.cols) + " x " + std::to_string(q.rows) + " tiles (1.." +
        std::to_string(Quilt::kMaxTiles) + " in all)");
  if (q.views > q.cols * q.rows)
    bad(std::to_string(q.views) + " views do not fit " + std::to_string(q.cols) + " x " +
        std::to_string(q.rows) + " tiles");
  if (width < q.cols || height < q.rows || width % q.cols != 0 || height % q.rows != 0)
    bad("a " + std::to_string(width) + "x" + std::to_string(height) + " frame is not " +
        std::to_string(q.cols) + " x " + std::to_string(q.rows) + " whole tiles");
  if (!std::isfinite(q.baseline) || q.baseline < 0)
    bad("baseline " + std::to_string(q.baseline) + " (finite, >= 0)");
}

cv::Rect quilt_tile(const Quilt& q, int width, int height, int i) {
  const int tw = width / q.cols, th = height / q.rows;
  const int col = i % q.cols, row = i / q.cols;  // row 0 at the bottom
  return {col * tw, (q.rows - 1 - row) * th, tw, th};
}

double convergence_distance(const ViewRequest& req) {
  const FocalPlane& p = req.focal_plane;
  if (p.at_infinity()) return std::numeric_limits<double>::infinity();
  const cv::Vec3d z(req.view.R(2, 0), req.view.R(2, 1), req.view.R(2, 2));
  const double nz = p.n.dot(z);
  const double t = nz == 0 ? -1 : -(p.n.dot(req.view.position) + p.d) / nz;
  return t > 0 && std::isfinite(t) ? t : std::numeric_limits<double>::infinity();
}

double baseline_for_cone(double distance, double cone_deg) {
  if (!std::isfinite(distance)) return 0;
  return 2.0 * distance * std::tan(0.5 * cone_deg * CV_PI / 180.0);
}

ViewRequest quilt_eye(const ViewRequest& req, int i) {
  const Quilt& q = req.quilt;
  if (q.empty()) throw std::invalid_argument("quilt_eye: the request is not a quilt");
  if (i < 0 || i >= q.views)
    throw std::invalid_argument("quilt_eye: view " + std::to_string(i) + " of " +
                                std::to_string(q.views));
  ViewRequest eye = req;
  eye.quilt = {};
  eye.view.width = req.view.width / q.cols;
  eye.view.height = req.view.height / q.rows;
  const double offset = q.baseline * (static_cast<double>(i) / (q.views - 1) - 0.5);
  const cv::Vec3d x(req.view.R(0, 0), req.view.R(0, 1), req.view.R(0, 2));
  eye.view.position = req.view.position + offset * x;
  const double d = convergence_distance(req);
  if (std::isfinite(d)) eye.view.shift_x = req.view.shift_x + eye.view.focal_px() * offset / d;
  return eye;
}

double array_extent(const Rig& rig, const cv::Vec3d& axis) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Camera& c : rig.cameras) {
    const double t = axis.dot(c.center());
    lo = std::min(lo, t), hi = std::max(hi, t);
  }
  return rig.cameras.empty() ? 0 : hi - lo;
}

std::string quilt_suffix(const Quilt& q, int width, int height) {
  const double aspect =
      static_cast<double>(width / std::max(1, q.cols)) / (height / std::max(1, q.rows));
  char buf[64];
  std::snprintf(buf, sizeof buf, "_qs%dx%da%.4g", q.cols, q.rows, aspect);
  return buf;
}

}  // namespace lf
