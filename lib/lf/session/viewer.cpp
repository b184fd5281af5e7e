#include "lf/session/viewer.h"

#include <algorithm>
#include <utility>

namespace lf {

void FocusSchedule::click(double x, double y) {
  pending_ = true, x_ = x, y_ = y;
  new_click_ = true, retries_ = 0;
}

std::optional<FocusSchedule::Probe> FocusSchedule::probe_for(uint64_t k, uint64_t retry_ticks,
                                                             bool continuous, int width,
                                                             int height) {
  // A click unanswered retry_ticks after its last probe: probed again.
  if (click_first_ && applied_ < click_first_ && !pending_ && retries_ < kClickRetries &&
      k >= click_tick_ + retry_ticks) {
    pending_ = true;
    ++retries_;
  }
  if (!pending_ && !(continuous && k % kContinuousEvery == 0)) return std::nullopt;
  Probe p;
  p.id = next_++;
  p.click = pending_;
  if (pending_) {
    click_probe_ = p.id, click_tick_ = k;
    if (new_click_) click_first_ = p.id, new_click_ = false;
  } else {
    continuous_probe_ = p.id;
  }
  pending_ = false;
  p.x = x_ >= 0 ? x_ : 0.5 * (width - 1);
  p.y = y_ >= 0 ? y_ : 0.5 * (height - 1);
  return p;
}

std::optional<double> FocusSchedule::answer(uint32_t id, double q, double current_q) {
  const bool click = click_first_ && id >= click_first_ && id <= click_probe_;
  const bool continuous = id > click_probe_ && id <= continuous_probe_;
  if (!(click || continuous) || id <= applied_) return std::nullopt;
  applied_ = id;
  return click ? q : current_q + kContinuousGain * (q - current_q);
}

SurfaceSchedule::Tick SurfaceSchedule::tick(uint64_t k, bool want, double focal_depth,
                                            const std::string& focal_plane, unsigned interval,
                                            bool first_wait_failed, int64_t now_us) {
  Tick t;
  if (want && focus_known_ && (focal_depth != last_depth_ || focal_plane != last_plane_))
    t.refocused = true, want = false;
  focus_known_ = true, last_depth_ = focal_depth, last_plane_ = focal_plane;
  if (!want) surface_ = {}, sent_ = false, given_up_ = false;
  if (want && !given_up_ && applied_ == 0 &&
      (first_wait_failed || (probe_ >= kGiveUpProbes && now_us - first_us_ >= kGiveUpAfterUs)))
    given_up_ = true, t.gave_up = true;
  if (want && !given_up_ && (!sent_ || k >= tick_ + interval)) {
    if (probe_ == 0) first_us_ = now_us;
    probe_ = t.probe = next_++;
    tick_ = k, sent_ = true;
  }
  return t;
}

bool SurfaceSchedule::answer(uint32_t id, FocalSurface surface) {
  if (id <= applied_ || id > probe_) return false;
  applied_ = id;
  surface_ = std::move(surface);
  return true;
}

std::optional<uint32_t> SurfaceSchedule::wait_for() {
  if (!sent_ || probe_ <= applied_ || waited_ == probe_) return std::nullopt;
  waited_ = probe_;
  return probe_;
}

bool key_moves_eye(const std::string& k, double step, EyeAndFocus* v) {
  if (k == "Left")
    v->eye[0] -= step / 4;
  else if (k == "Right")
    v->eye[0] += step / 4;
  else if (k == "Up")
    v->eye[1] -= step / 4;
  else if (k == "Down")
    v->eye[1] += step / 4;
  else if (k == "Page_Up" || k == "Prior" || k == "plus" || k == "equal" || k == "KP_Add")
    v->eye[2] += step;
  else if (k == "Page_Down" || k == "Next" || k == "minus" || k == "KP_Subtract")
    v->eye[2] -= step;
  else if (k == "r")
    v->eye = {0, 0, 0}, v->focal_depth = 0;
  else
    return false;
  return true;
}

void drag_moves_eye(double dx, double dy, double step, EyeAndFocus* v) {
  v->eye[0] -= dx * step / 40.0;
  v->eye[1] -= dy * step / 40.0;
}

void wheel_moves_focus(double notches, double fx, double step, double current_q, double max_depth,
                       EyeAndFocus* v) {
  const double q = std::max(0.0, current_q + notches * 0.25 / (fx * step));
  v->focal_depth = q > 1.0 / max_depth ? 1.0 / q : max_depth;
}

std::vector<ViewRequest> tick_requests(const Rig& rig, ViewRequest req, const TickShape& shape) {
  const cv::Vec3d x(req.view.R(0, 0), req.view.R(0, 1), req.view.R(0, 2));
  if (shape.quilt.views > 0) {
    req.quilt = shape.quilt;
    req.quilt.baseline = shape.quilt_baseline > 0 ? shape.quilt_baseline
                         : shape.view_cone > 0
                             ? baseline_for_cone(convergence_distance(req), shape.view_cone)
                             : array_extent(rig, x);
    if (!(req.quilt.baseline > 0))  // a cone focused at infinity, a one-camera rig
      req.quilt.baseline = rig.typical_spacing();
    req.view.width *= req.quilt.cols;
    req.view.height *= req.quilt.rows;
    return {req};
  }
  if (!(shape.stereo_baseline > 0)) return {req};
  ViewRequest left = req, right = req;
  right.viewer_id = req.viewer_id + 1;
  right.view.position += x * (0.5 * shape.stereo_baseline);
  left.view.position -= x * (0.5 * shape.stereo_baseline);
  return {left, right};
}

}  // namespace lf
