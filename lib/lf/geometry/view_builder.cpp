#include "lf/geometry/view_builder.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "lf/io/path_file.h"

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

namespace {

// The nearest point to `q` of segment ab.
cv::Vec2d nearest_on_segment(const cv::Vec2d& q, const cv::Vec2d& a, const cv::Vec2d& b) {
  const cv::Vec2d ab = b - a;
  const double len2 = ab.dot(ab);
  const double t = len2 > 0 ? std::clamp((q - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
  return a + ab * t;
}

// Whether q lies inside triangle abc, at least `margin` from each side.
bool inside_triangle(const cv::Vec2d& q, const cv::Vec2d& a, const cv::Vec2d& b, const cv::Vec2d& c,
                     double margin) {
  const cv::Vec2d v[3] = {a, b, c};
  const double area2 = (b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0];
  if (area2 == 0) return false;
  for (int i = 0; i < 3; ++i) {
    const cv::Vec2d e = v[(i + 1) % 3] - v[i];
    const double cross = e[0] * (q - v[i])[1] - e[1] * (q - v[i])[0];
    if ((area2 > 0 ? cross : -cross) < margin * cv::norm(e)) return false;
  }
  return true;
}

}  // namespace

cv::Vec2d clamp_to_array(const Rig& rig, const cv::Vec2d& st) {
  const auto& pos = rig.plane_positions();
  const double step = 1e-3 * rig.typical_spacing();
  if (!rig.triangles.empty()) {
    // A 2D array: the union of its triangles, which on a real (irregular)
    // rig is smaller than the convex hull of the cameras (a grid's border
    // cameras do not lie on a line); between the two no triangle's aperture
    // covers the eye and the view would be black.
    cv::Vec2d best = st;
    double best_d = 1e300;
    for (const auto& tri : rig.triangles) {
      const int ia = rig.index_of(tri[0]), ib = rig.index_of(tri[1]), ic = rig.index_of(tri[2]);
      if (ia < 0 || ib < 0 || ic < 0) continue;
      const cv::Vec2d a = pos[ia], b = pos[ib], c = pos[ic];
      if (inside_triangle(st, a, b, c, 0.0)) return st;
      // The nearest point of this triangle, moved 1e-3 camera spacing towards
      // its centroid (an eye exactly on a border edge is on no simplex: the
      // tie rule gives boundary points to the outside).
      for (const auto& [u, v] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) {
        const cv::Vec2d p = nearest_on_segment(st, u, v);
        const double d = cv::norm(st - p);
        if (d < best_d) {
          const cv::Vec2d in = (a + b + c) / 3.0 - p;
          const double n = cv::norm(in);
          best_d = d, best = n > step ? p + in * (step / n) : (a + b + c) / 3.0;
        }
      }
    }
    if (best_d < 1e300) return best;
  }
  // A linear array: the nearest point of its segment; one camera: the camera.
  cv::Vec2d centre(0, 0);
  for (const cv::Vec2d& p : pos) centre += p;
  centre /= static_cast<double>(pos.size());
  size_t a = 0, b = 0;
  for (size_t i = 0; i < pos.size(); ++i)
    for (size_t j = 0; j < pos.size(); ++j)
      if (cv::norm(pos[i] - pos[j]) > cv::norm(pos[a] - pos[b])) a = i, b = j;
  const cv::Vec2d p = nearest_on_segment(st, pos[a], pos[b]);
  const cv::Vec2d in = centre - p;
  const double n = cv::norm(in);
  if (cv::norm(st - p) == 0) return st;
  return n > step ? p + in * (step / n) : centre;
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
