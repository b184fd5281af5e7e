#include "lf/geometry/view.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#if defined(__SSE2__) && !defined(LF_NO_SIMD)
#include <emmintrin.h>
#endif

namespace lf {

namespace {

// Whether a focal surface's tile entries are all valid: plane_of[t] <
// planes, and second_of[t] kNone or < planes and not plane_of[t] (second
// null: not checked); planes in 1..FocalSurface::kMaxPlanes. Sixteen tiles
// at a time where SSE2 is there: every camera of a process validates each
// request (64 a frame, 8160 tiles each at 1920x1080).
bool tiles_valid(const uint8_t* first, const uint8_t* second, size_t n, size_t planes) {
  size_t t = 0;
#if defined(__SSE2__) && !defined(LF_NO_SIMD)
  const __m128i limit = _mm_set1_epi8(static_cast<char>(planes - 1));
  const __m128i none = _mm_set1_epi8(static_cast<char>(FocalSurface::kNone));
  const __m128i ones = _mm_set1_epi8(-1);
  __m128i bad = _mm_setzero_si128();
  for (; t + 16 <= n; t += 16) {
    // k > limit (unsigned): max(k, limit) != limit.
    const __m128i p = _mm_loadu_si128(reinterpret_cast<const __m128i*>(first + t));
    bad = _mm_or_si128(bad, _mm_xor_si128(_mm_cmpeq_epi8(_mm_max_epu8(p, limit), limit), ones));
    if (!second) continue;
    const __m128i k = _mm_loadu_si128(reinterpret_cast<const __m128i*>(second + t));
    const __m128i over = _mm_xor_si128(_mm_cmpeq_epi8(_mm_max_epu8(k, limit), limit), ones);
    const __m128i wrong = _mm_or_si128(over, _mm_cmpeq_epi8(k, p));
    bad = _mm_or_si128(bad, _mm_andnot_si128(_mm_cmpeq_epi8(k, none), wrong));
  }
  if (_mm_movemask_epi8(bad)) return false;
#endif
  for (; t < n; ++t) {
    if (first[t] >= planes) return false;
    if (second && second[t] != FocalSurface::kNone &&
        (second[t] >= planes || second[t] == first[t]))
      return false;
  }
  return true;
}

}  // namespace

FocalPlane FocalPlane::through(const cv::Vec3d& p, const cv::Vec3d& normal) {
  const cv::Vec3d n = normal / cv::norm(normal);
  return {n, -n.dot(p)};
}

double VirtualView::focal_px() const {
  return 0.5 * height / std::tan(0.5 * vfov_deg * CV_PI / 180.0);
}

Intrinsics VirtualView::intrinsics() const {
  Intrinsics k;
  k.fx = k.fy = focal_px();
  k.cx = 0.5 * (width - 1) + shift_x;
  k.cy = 0.5 * (height - 1) + shift_y;
  return k;
}

VirtualView VirtualView::from_camera(const Camera& cam, int width, int height) {
  const Intrinsics& k = cam.intrinsics;
  if (std::abs(k.fx - k.fy) > 1e-9 * k.fx)
    throw std::invalid_argument("VirtualView::from_camera: camera " + std::to_string(cam.id) +
                                " has fx != fy; virtual views have square pixels");
  // Scale so that the camera's image height maps onto the output height, and
  // centre the output horizontally on the camera's image (cropping or
  // padding the width when aspect ratios differ).
  const double s = static_cast<double>(height) / cam.height;
  const Intrinsics ks = k.scaled(s);
  const double crop_x = 0.5 * (cam.width * s - width);  // pixels cut on the left
  VirtualView v;
  v.position = cam.center();
  v.R = cam.extrinsics.R;
  v.width = width;
  v.height = height;
  v.vfov_deg = 2.0 * std::atan(0.5 * height / ks.fy) * 180.0 / CV_PI;
  v.shift_x = (ks.cx - crop_x) - 0.5 * (width - 1);
  v.shift_y = ks.cy - 0.5 * (height - 1);
  return v;
}

VirtualView VirtualView::look_at(const cv::Vec3d& eye, const cv::Vec3d& target,
                                 const cv::Vec3d& down, double vfov_deg, int width, int height) {
  cv::Vec3d z = target - eye;
  if (cv::norm(z) == 0) throw std::invalid_argument("look_at: eye equals target");
  z /= cv::norm(z);
  cv::Vec3d x = down.cross(z);
  if (cv::norm(x) < 1e-12) throw std::invalid_argument("look_at: 'down' is parallel to the view");
  x /= cv::norm(x);
  const cv::Vec3d y = z.cross(x);
  VirtualView v;
  v.position = eye;
  v.R = cv::Matx33d(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
  v.vfov_deg = vfov_deg;
  v.width = width;
  v.height = height;
  return v;
}

void validate(const ViewRequest& req) {
  auto bad = [](const std::string& what) { throw std::invalid_argument("view request: " + what); };
  const VirtualView& v = req.view;
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(v.position[i])) bad("position is not finite");
  for (int i = 0; i < 9; ++i)
    if (!std::isfinite(v.R.val[i])) bad("orientation is not finite");
  if (cv::norm(v.R * v.R.t() - cv::Matx33d::eye(), cv::NORM_INF) > 1e-6 || cv::determinant(v.R) < 0)
    bad("orientation is not a rotation matrix");
  if (!(v.vfov_deg > 0.0 && v.vfov_deg <= 179.9))
    bad("vertical field of view " + std::to_string(v.vfov_deg) + " deg is outside (0, 179.9]");
  if (v.width < 1 || v.height < 1 || v.width > 16384 || v.height > 16384)
    bad("output size " + std::to_string(v.width) + "x" + std::to_string(v.height) +
        " is outside 1..16384");
  if (!std::isfinite(v.shift_x) || !std::isfinite(v.shift_y)) bad("lens shift is not finite");
  const FocalPlane& p = req.focal_plane;
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(p.n[i])) bad("focal plane normal is not finite");
  if (!std::isfinite(p.d)) bad("focal plane offset is not finite");
  if (p.at_infinity() && p.d == 0.0) bad("focal plane (0, 0, 0, 0) is not a plane");
  if (req.aperture != Aperture::kTent && req.aperture != Aperture::kUlr &&
      req.aperture != Aperture::kFourCamera)
    bad("unknown aperture");
  if (req.aperture == Aperture::kFourCamera && req.aperture_scale != 1.0)
    bad("four-camera weights have no scale");
  if (req.aperture == Aperture::kUlr &&
      (req.ulr_cameras < kMinUlrCameras || req.ulr_cameras > kMaxUlrCameras))
    bad("ULR aperture with " + std::to_string(req.ulr_cameras) + " cameras (" +
        std::to_string(kMinUlrCameras) + ".." + std::to_string(kMaxUlrCameras) + ")");
  if (req.aperture == Aperture::kUlr && req.aperture_scale != 1.0)
    bad("a ULR aperture has no scale");
  if (req.sampling != Sampling::kBilinear && req.sampling != Sampling::kBicubic)
    bad("unknown sampling filter");
  if (!(req.aperture_scale >= 1.0 && req.aperture_scale <= kMaxApertureScale))
    bad("aperture scale " + std::to_string(req.aperture_scale) + " is outside 1.." +
        std::to_string(static_cast<int>(kMaxApertureScale)));
  const FocalSurface& fs = req.surface;
  if (!req.quilt.empty()) {
    if (!fs.empty()) bad("a quilt has one focal plane for all its eyes, not a focal surface");
    try {
      validate_quilt(req.quilt, v.width, v.height);
    } catch (const std::invalid_argument& e) {
      bad(e.what());
    }
  }
  if (fs.empty()) return;
  if (fs.tile < FocalSurface::kMinTile || fs.tile > FocalSurface::kMaxTile)
    bad("focal surface tile " + std::to_string(fs.tile) + " px is outside " +
        std::to_string(FocalSurface::kMinTile) + ".." + std::to_string(FocalSurface::kMaxTile));
  if (fs.cols != (v.width + fs.tile - 1) / fs.tile || fs.rows != (v.height + fs.tile - 1) / fs.tile)
    bad("focal surface grid " + std::to_string(fs.cols) + "x" + std::to_string(fs.rows) +
        " does not cover the " + std::to_string(v.width) + "x" + std::to_string(v.height) +
        " output in tiles of " + std::to_string(fs.tile));
  if (fs.planes.empty() || fs.planes.size() > FocalSurface::kMaxPlanes)
    bad("focal surface has " + std::to_string(fs.planes.size()) + " planes (1.." +
        std::to_string(FocalSurface::kMaxPlanes) + ")");
  for (const FocalPlane& q : fs.planes) {
    if (!std::isfinite(q.n[0]) || !std::isfinite(q.n[1]) || !std::isfinite(q.n[2]) ||
        !std::isfinite(q.d))
      bad("focal surface plane is not finite");
    if (q.at_infinity() && q.d == 0.0) bad("focal surface plane (0, 0, 0, 0) is not a plane");
  }
  if (fs.plane_of.size() != static_cast<size_t>(fs.cols) * fs.rows)
    bad("focal surface has " + std::to_string(fs.plane_of.size()) + " tile entries for " +
        std::to_string(fs.cols * fs.rows) + " tiles");
  const bool two = !fs.second_of.empty();
  if ((!two || fs.second_of.size() == fs.plane_of.size()) &&
      tiles_valid(fs.plane_of.data(), two ? fs.second_of.data() : nullptr, fs.plane_of.size(),
                  fs.planes.size()))
    return;
  // What is wrong, first problem first.
  for (uint8_t k : fs.plane_of)
    if (k >= fs.planes.size()) bad("focal surface tile names plane " + std::to_string(k));
  if (!two) return;
  if (fs.second_of.size() != fs.plane_of.size())
    bad("focal surface has " + std::to_string(fs.second_of.size()) + " second-plane entries for " +
        std::to_string(fs.plane_of.size()) + " tiles");
  for (size_t t = 0; t < fs.second_of.size(); ++t) {
    const uint8_t k = fs.second_of[t];
    if (k == FocalSurface::kNone) continue;
    if (k >= fs.planes.size()) bad("focal surface tile names second plane " + std::to_string(k));
    if (k == fs.plane_of[t]) bad("focal surface tile's second plane is its first");
  }
}

bool FocalSurface::two_planes() const {
  return std::any_of(second_of.begin(), second_of.end(), [](uint8_t k) { return k != kNone; });
}

int FocalSurface::two_plane_tiles() const {
  return static_cast<int>(
      std::count_if(second_of.begin(), second_of.end(), [](uint8_t k) { return k != kNone; }));
}

int FocalSurface::planes_used() const {
  std::vector<bool> used(planes.size(), false);
  for (uint8_t k : plane_of)
    if (k < used.size()) used[k] = true;
  for (uint8_t k : second_of)
    if (k < used.size()) used[k] = true;
  return static_cast<int>(std::count(used.begin(), used.end(), true));
}

double aperture_diameter(double scale, double spacing) {
  return 2.0 * spacing * scale;
}

double aperture_scale_for(double diameter, double spacing) {
  if (!(spacing > 0) || !std::isfinite(diameter)) return 1.0;
  return std::clamp(diameter / (2.0 * spacing), 1.0, kMaxApertureScale);
}

double full_frame_f_number(double diameter_mm, double fx, int width) {
  if (!(diameter_mm > 0) || width <= 0) return 0.0;
  return 36.0 * fx / width / diameter_mm;
}

double diameter_for_f_number(double f_number, double fx, int width, double mm_per_unit) {
  if (!(f_number > 0) || !(mm_per_unit > 0) || width <= 0) return 0.0;
  return 36.0 * fx / width / f_number / mm_per_unit;
}

double millimetres_per_unit(const std::string& unit) {
  if (unit == "mm") return 1.0;
  if (unit == "cm") return 10.0;
  if (unit == "m") return 1000.0;
  return 0.0;
}

}  // namespace lf
