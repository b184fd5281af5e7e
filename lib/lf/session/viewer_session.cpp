#include "lf/session/viewer_session.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "lf/focus/focus.h"
#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/io/parse.h"
#include "lf/wire/wire.h"

namespace lf {
namespace {

std::optional<cv::Vec3d> point(const std::vector<double>& p, const char* what) {
  if (p.empty()) return std::nullopt;
  if (p.size() != 3 || !std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
    throw std::invalid_argument(std::string(what) + " needs 3 finite numbers, <x, y, z>");
  return cv::Vec3d(p[0], p[1], p[2]);
}

// The quilt layout of the settings (its baseline is set per request).
Quilt quilt_of(const ViewerSettings& s) {
  Quilt q;
  q.views = static_cast<int>(s.quilt_views);
  q.cols = static_cast<int>(s.quilt_cols), q.rows = static_cast<int>(s.quilt_rows);
  return q;
}

// Runs `f`; a std::exception becomes a notice of `kind`.
template <class F>
bool noting(ViewerTick* t, ViewerNotice::Kind kind, F&& f) {
  try {
    f();
    return true;
  } catch (const std::exception& e) {
    t->notices.push_back({kind, e.what()});
    return false;
  }
}

}  // namespace

std::shared_ptr<const ViewerViews> build_viewer_views(const ViewerSettings& s, const Rig& rig) {
  auto v = std::make_shared<ViewerViews>();
  v->s = s;
  ViewSettings vs;
  vs.width = s.width;
  vs.height = s.height;
  if (s.quilt_views > 0) {  // each eye has the tile's size
    validate_quilt(quilt_of(s), s.width, s.height);
    if (s.stereo_baseline > 0)
      throw std::invalid_argument("a quilt (quilt-views) and stereo-baseline cannot be combined");
    vs.width = s.width / static_cast<int>(s.quilt_cols);
    vs.height = s.height / static_cast<int>(s.quilt_rows);
  }
  vs.position = point(s.position, "position");
  vs.look_at = point(s.look_at, "look-at");
  vs.vfov_deg = s.vfov;
  vs.path_file = s.path;
  vs.orbit = s.orbit;
  vs.dolly = s.dolly;
  vs.path_frames = s.path_frames;
  v->sequence = build_views(rig, vs);
  v->plane = s.focal_depth > 0 ? plane_at_inverse_depth(rig, 1.0 / s.focal_depth)
                               : parse_focal_plane(s.focal_plane, rig);
  return v;
}

ViewerSession::ViewerSession(std::shared_ptr<const Rig> rig, unsigned viewer_id,
                             std::shared_ptr<const ViewerViews> views)
    : rig_(std::move(rig)), viewer_id_(viewer_id), views_(std::move(views)) {}

std::optional<EyeAndFocus> ViewerSession::navigate(const Gesture& g, const ViewerSettings& now,
                                                   double max_depth) {
  const Rig& rig = *rig_;
  const double step = rig.typical_spacing();
  EyeAndFocus v{{now.eye_s, now.eye_t, now.eye_w}, now.focal_depth};
  bool changed = false;
  double notches = 0;
  bool scroll = false;
  switch (g.kind) {
    case Gesture::Kind::kPress:
      // Click to focus: button 3 (right), or button 1 with Control.
      if (g.button == 3 || (g.button == 1 && g.control)) {
        focus_.click(g.x, g.y);
        return std::nullopt;
      }
      if (g.button == 1) dragging_ = true, drag_x_ = g.x, drag_y_ = g.y;
      // X sinks (ximagesink, xvimagesink) send the wheel as buttons 4/5.
      if (g.button == 4 || g.button == 5) scroll = true, notches = g.button == 4 ? 1 : -1;
      break;
    case Gesture::Kind::kRelease:
      if (g.button == 1) dragging_ = false;
      break;
    case Gesture::Kind::kMove:
      if (dragging_) {
        // Drag: move the eye on the camera plane, 1/40 camera spacing per pixel.
        drag_moves_eye(g.x - drag_x_, g.y - drag_y_, step, &v);
        drag_x_ = g.x, drag_y_ = g.y;
        changed = true;
      }
      break;
    case Gesture::Kind::kScroll:
      scroll = true, notches = g.dy;
      break;
    case Gesture::Kind::kKey:
      changed = key_moves_eye(g.key, step, &v);
      break;
  }
  if (scroll) {
    // Wheel: focal plane nearer/farther by 0.25 px of parallax between
    // neighbouring cameras per notch.
    const double q0 =
        v.focal_depth > 0 ? 1.0 / v.focal_depth : inverse_depth_of(rig, views_->plane);
    wheel_moves_focus(notches, rig.cameras[0].intrinsics.fx, step, q0, max_depth, &v);
    changed = true;
  }
  if (!changed) return std::nullopt;
  // Keep the eye over the camera array (off it the picture would be black).
  cv::Vec2d base(0, 0);
  if (now.position.size() == 3)
    base = rig.plane().to_plane({now.position[0], now.position[1], now.position[2]});
  const cv::Vec2d st = clamp_to_array(rig, base + cv::Vec2d(v.eye[0], v.eye[1])) - base;
  v.eye[0] = st[0], v.eye[1] = st[1];
  return v;
}

std::optional<double> ViewerSession::focus_answer(uint32_t probe, double q, double focal_depth,
                                                  double max_depth) {
  const double current =
      focal_depth > 0 ? 1.0 / focal_depth : inverse_depth_of(*rig_, views_->plane);
  const std::optional<double> to = focus_.answer(probe, q, current);
  if (!to) return std::nullopt;
  return *to > 1.0 / max_depth ? 1.0 / *to : max_depth;
}

const char* ViewerNotice::summary() const {
  switch (kind) {
    case Kind::kBadEyeOffset:
      return "Ignoring the eye offset: the view it gives is invalid";
    case Kind::kFNumberIgnored:
      return "Ignoring f-number";
    case Kind::kSurfaceMisfit:
      return "Ignoring a focal surface that does not fit the view";
    default:
      return nullptr;
  }
}

ViewerTick ViewerSession::tick(uint64_t k, const ViewerSettings& now, int64_t period_us,
                               int64_t now_us, bool first_wait_failed) {
  ViewerTick out;
  const Rig& rig = *rig_;
  const ViewerSettings& s = views_->s;
  ViewRequest req;
  req.viewer_id = viewer_id_;
  req.sequence = k;
  req.focal_plane = views_->plane;
  if (!noting(&out, ViewerNotice::Kind::kBadEyeOffset, [&] {
        req.view = views_->sequence.at(k, rig, camera_plane_offset(rig, s.eye_s, s.eye_t, s.eye_w));
        validate(req);
      }))
    req.view = views_->sequence.at(k, rig);
  // The aperture (its f-number needs the view's focal length) and sampling.
  if (s.ulr_cameras > 0) {
    req.aperture = Aperture::kUlr;
    req.ulr_cameras = std::max<int>(kMinUlrCameras, static_cast<int>(s.ulr_cameras));
  } else if (s.four_camera && s.aperture <= 0 && s.f_number <= 0) {
    req.aperture = Aperture::kFourCamera;
  } else {
    double diameter = s.aperture;
    if (s.f_number > 0) {
      const double mm = millimetres_per_unit(rig.unit);
      if (mm > 0)
        diameter = diameter_for_f_number(s.f_number, req.view.focal_px(), req.view.width, mm);
      else
        out.notices.push_back({ViewerNotice::Kind::kFNumberIgnored,
                               "the rig's unit '" + rig.unit +
                                   "' is not a length (mm, cm or m): set aperture in rig units"});
    }
    req.aperture_scale = aperture_scale_for(diameter, rig.typical_spacing());
  }
  req.sampling = s.sampling;
  // A focus probe (lf::FocusSchedule), then a surface probe every
  // surface-interval ticks (lf::SurfaceSchedule; the first at once), of the
  // view without its surface. A quilt's eyes share one focal plane
  // (lib/lf/render/quilt.h): no surface.
  const uint64_t retry_ticks =
      std::max<uint64_t>(kClickRetryTicks, (kClickRetryAfterUs + period_us - 1) / period_us);
  if (const auto fp =
          focus_.probe_for(k, retry_ticks, now.continuous_focus, req.view.width, req.view.height)) {
    out.focus_probe = fp;
    noting(&out, ViewerNotice::Kind::kNoFocusProbe,
           [&] { out.probes.push_back(focus_probe_requests(rig, req, fp->x, fp->y, fp->id)); });
  }
  const bool want_surface = s.quilt_views == 0 && now.focal_surface;
  const SurfaceSchedule::Tick sp = surface_.tick(k, want_surface, now.focal_depth, now.focal_plane,
                                                 now.surface_interval, first_wait_failed, now_us);
  out.refocused = sp.refocused, out.gave_up = sp.gave_up;
  out.surface_probes_sent = surface_.probes_sent();
  if (sp.probe) {
    out.surface_probe = sp.probe;
    noting(&out, ViewerNotice::Kind::kNoSurfaceProbe,
           [&] { out.probes.push_back(surface_probe_requests(rig, req, sp.probe)); });
  }
  out.probes.erase(std::remove_if(out.probes.begin(), out.probes.end(),
                                  [](const std::vector<ViewRequest>& v) { return v.empty(); }),
                   out.probes.end());
  // The surface in use, if any, goes into the request (checked against the
  // view: one that does not fit is dropped).
  if (const FocalSurface& surface = surface_.surface(); !surface.empty()) {
    ViewRequest with = req;
    with.focal_plane = surface.planes[0];
    if (surface.planes_used() > 1) with.surface = surface;
    if (noting(&out, ViewerNotice::Kind::kSurfaceMisfit, [&] { validate(with); })) {
      req = std::move(with);
      out.surface_planes = static_cast<unsigned>(surface.planes_used());
      out.two_plane_tiles = static_cast<unsigned>(req.surface.two_plane_tiles());
    } else {
      surface_.drop_surface();
    }
  }
  // The quilt's one request, or the stereo pair, or the view alone.
  TickShape shape;
  if (s.quilt_views > 0) shape.quilt = quilt_of(s);
  shape.quilt_baseline = s.quilt_baseline, shape.view_cone = s.view_cone;
  shape.stereo_baseline = s.stereo_baseline;
  out.requests = tick_requests(rig, req, shape);
  return out;
}

}  // namespace lf
