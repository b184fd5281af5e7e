#include "lf/view_builder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "lf/path_file.h"

namespace lf {

VirtualView view_between_cameras(const Rig& rig, const cv::Vec3d& eye, int width, int height) {
  const cv::Vec2d X = rig.plane().to_plane(eye);
  const auto& pos = rig.plane_positions();
  int nearest = 0;
  for (size_t i = 1; i < pos.size(); ++i)
    if (cv::norm(pos[i] - X) < cv::norm(pos[nearest] - X)) nearest = static_cast<int>(i);
  Camera cam = rig.cameras[nearest];
  // Barycentric interpolation of the intrinsics over the simplex under X.
  for (const Simplex& s : rig.simplices()) {
    if (s.size == 1) break;
    std::array<double, 3> e{0, 0, 0};
    double sum = 0;
    bool in = true;
    for (int k = 0; k < s.size; ++k) {
      const Form2& f = rig.facets()[s.facet[k]];
      e[k] = s.sign[k] * f(X);
      if (e[k] < -1e-12 * rig.typical_spacing() * rig.typical_spacing()) in = false;
      sum += e[k];
    }
    if (!in || !(sum > 0)) continue;
    Intrinsics k{0, 0, 0, 0, 0, 0};
    for (int j = 0; j < s.size; ++j) {
      const Intrinsics& kj = rig.cameras[s.cams[j]].intrinsics;
      const double w = std::max(0.0, e[j]) / sum;
      k.fx += w * kj.fx, k.fy += w * kj.fy, k.cx += w * kj.cx, k.cy += w * kj.cy;
    }
    cam.intrinsics = k;
    break;
  }
  cam.intrinsics.fx = cam.intrinsics.fy = 0.5 * (cam.intrinsics.fx + cam.intrinsics.fy);
  cam.intrinsics.k1 = cam.intrinsics.k2 = 0;
  cam.extrinsics = Extrinsics::from_center(cam.extrinsics.R, eye);
  return VirtualView::from_camera(cam, width, height);
}

std::vector<Keyframe> orbit_path(const Rig& rig, double fraction, double dolly, int frames) {
  const CameraPlane& P = rig.plane();
  double ext_s = 0, ext_t = 0;
  for (const auto& p : rig.plane_positions())
    ext_s = std::max(ext_s, std::abs(p[0])), ext_t = std::max(ext_t, std::abs(p[1]));
  std::vector<Keyframe> keys;
  for (int k = 0; k < frames; ++k) {
    const double a = 2 * CV_PI * k / frames;
    Keyframe kf;
    kf.position = P.origin + P.u * (fraction * ext_s * std::cos(a)) +
                  P.v * (fraction * ext_t * std::sin(a)) + P.normal * (dolly * std::sin(2 * a));
    keys.push_back(kf);
  }
  return keys;
}

namespace {
cv::Vec3d catmull(const cv::Vec3d& p0, const cv::Vec3d& p1, const cv::Vec3d& p2,
                  const cv::Vec3d& p3, double t) {
  const double t2 = t * t, t3 = t2 * t;
  return 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2 +
                (-p0 + 3 * p1 - 3 * p2 + p3) * t3);
}
}  // namespace

std::vector<VirtualView> sample_path(const Rig& rig, const std::vector<Keyframe>& keys, int frames,
                                     int width, int height, bool closed) {
  std::vector<VirtualView> out;
  const int n = static_cast<int>(keys.size());
  for (int f = 0; f < frames; ++f) {
    const double u = closed ? static_cast<double>(f) * n / frames
                            : (frames > 1 ? static_cast<double>(f) * (n - 1) / (frames - 1) : 0);
    int i = std::min(static_cast<int>(std::floor(u)), closed ? n - 1 : n - 2);
    const double t = u - i;
    auto at = [&](int k) -> const Keyframe& {
      if (closed) return keys[((k % n) + n) % n];
      return keys[std::clamp(k, 0, n - 1)];
    };
    const cv::Vec3d pos =
        catmull(at(i - 1).position, at(i).position, at(i + 1).position, at(i + 2).position, t);
    const Keyframe& a = at(i);
    const Keyframe& b = at(i + 1);
    if (a.has_look_at && b.has_look_at) {
      const cv::Vec3d target = a.look_at * (1 - t) + b.look_at * t;
      const double vfov = (a.vfov > 0 && b.vfov > 0) ? a.vfov * (1 - t) + b.vfov * t : 50.0;
      cv::Vec3d down(rig.cameras[0].extrinsics.R(1, 0), rig.cameras[0].extrinsics.R(1, 1),
                     rig.cameras[0].extrinsics.R(1, 2));
      out.push_back(VirtualView::look_at(pos, target, down, vfov, width, height));
    } else {
      out.push_back(view_between_cameras(rig, pos, width, height));
    }
  }
  return out;
}

cv::Vec3d point_on_camera_plane(const Rig& rig, double x, double y) {
  const CameraPlane& P = rig.plane();
  if (std::abs(P.normal[2]) < 1e-9)
    throw std::invalid_argument("the camera plane is vertical here: give x, y and z");
  return {x, y,
          P.origin[2] -
              (P.normal[0] * (x - P.origin[0]) + P.normal[1] * (y - P.origin[1])) / P.normal[2]};
}

cv::Vec3d camera_plane_offset(const Rig& rig, double s, double t, double w) {
  const CameraPlane& P = rig.plane();
  return P.u * s + P.v * t + P.normal * w;
}

cv::Vec2d clamp_to_array(const Rig& rig, const cv::Vec2d& st) {
  std::vector<cv::Point2f> pts, hull;
  for (const cv::Vec2d& p : rig.plane_positions())
    pts.emplace_back(static_cast<float>(p[0]), static_cast<float>(p[1]));
  cv::Vec2d centre(0, 0);
  for (const cv::Vec2d& p : rig.plane_positions()) centre += p;
  centre /= static_cast<double>(pts.size());
  if (pts.size() >= 3) cv::convexHull(pts, hull);
  const cv::Point2f q(static_cast<float>(st[0]), static_cast<float>(st[1]));
  if (hull.size() >= 3 && cv::pointPolygonTest(hull, q, true) > 0) return st;
  // The nearest point of the hull's boundary (of the segment, for a linear
  // array; the camera, for one)...
  if (hull.size() < 3) {
    hull.clear();
    size_t a = 0, b = 0;
    for (size_t i = 0; i < pts.size(); ++i)
      for (size_t j = 0; j < pts.size(); ++j)
        if (cv::norm(pts[i] - pts[j]) > cv::norm(pts[a] - pts[b])) a = i, b = j;
    hull = {pts[a], pts[b]};
  }
  cv::Vec2d best = centre;
  double best_d = 1e300;
  for (size_t i = 0; i < hull.size(); ++i) {
    const cv::Vec2d a(hull[i].x, hull[i].y);
    const cv::Vec2d b(hull[(i + 1) % hull.size()].x, hull[(i + 1) % hull.size()].y);
    const cv::Vec2d ab = b - a;
    const double len2 = ab.dot(ab);
    const double t = len2 > 0 ? std::clamp((st - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const cv::Vec2d p = a + ab * t;
    if (cv::norm(st - p) < best_d) best_d = cv::norm(st - p), best = p;
  }
  // ...moved 1e-3 camera spacing towards the centre: an eye exactly on the
  // boundary is on no simplex (the tie rule gives boundary points to the
  // outside), and its view would be black.
  const cv::Vec2d in = centre - best;
  const double n = cv::norm(in), step = 1e-3 * rig.typical_spacing();
  return n > step ? best + in * (step / n) : centre;
}

VirtualView ViewSequence::at(uint64_t k, const Rig& rig, const cv::Vec3d& offset) const {
  VirtualView v = views[k % views.size()];
  if (offset == cv::Vec3d(0, 0, 0)) return v;
  if (follows_cameras) return view_between_cameras(rig, v.position + offset, v.width, v.height);
  v.position += offset;
  return v;
}

ViewSequence build_views(const Rig& rig, const ViewSettings& s) {
  if (s.width < 1 || s.height < 1) throw std::invalid_argument("output size must be positive");
  if (!(s.vfov_deg >= 0) || !std::isfinite(s.vfov_deg))
    throw std::invalid_argument("vfov must be finite and >= 0");
  ViewSequence seq;
  const int frames = std::max(1, s.path_frames);
  if (!s.path_file.empty()) {
    seq.views = sample_path(rig, load_path(s.path_file), frames, s.width, s.height, false);
  } else if (s.orbit > 0) {
    seq.views =
        sample_path(rig, orbit_path(rig, s.orbit, s.dolly, 24), frames, s.width, s.height, true);
  } else {
    const cv::Vec3d eye = s.position ? *s.position : rig.plane().origin;
    if (s.look_at) {
      // "Down" follows the first camera's y axis.
      const cv::Matx33d& R = rig.cameras[0].extrinsics.R;
      seq.views.push_back(VirtualView::look_at(eye, *s.look_at, {R(1, 0), R(1, 1), R(1, 2)},
                                               s.vfov_deg > 0 ? s.vfov_deg : 50.0, s.width,
                                               s.height));
    } else {
      seq.views.push_back(view_between_cameras(rig, eye, s.width, s.height));
      if (s.vfov_deg > 0) seq.views.back().vfov_deg = s.vfov_deg;
      seq.follows_cameras = s.vfov_deg <= 0;
    }
  }
  ViewRequest probe;
  probe.view = seq.views.front();
  validate(probe);
  return seq;
}

}  // namespace lf
