#include "lf/session/compositor_host.h"

#include <algorithm>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>

#include "lf/focus/focus_probe.h"
#include "lf/focus/surface_probe.h"
#include "lf/render/composite.h"

namespace lf {

void FrameCompositor::composite_eye(int eye, const std::vector<FragmentPixels>& frags,
                                    const std::vector<const DeferredDrawing*>& deferred, int width,
                                    int height, cv::Mat& into, Result& r) {
  std::vector<SlotDrawing> drawings;
  for (const DeferredDrawing* d : deferred) {
    renderer_->set_image(d->slot, d->image, d->frame_key, d->frame_pts);
    drawings.push_back({&d->plan, &d->camera, d->slot});
  }
  for (auto& [i, why] : renderer_->composite(eye, width, height, frags, drawings, into))
    r.refused.emplace_back(i < frags.size() ? static_cast<int>(frags[i].fragment->camera_id)
                                            : drawings[i - frags.size()].camera->id,
                           std::move(why));
}

FrameCompositor::Result FrameCompositor::composite(const std::vector<ReceivedPiece>& pieces,
                                                   int width, int height, bool stereo,
                                                   uint32_t left_viewer, bool complete) {
  // Each eye's fragments and drawings, composited at once by the renderer
  // (the CPU draws each band of rows' part of every drawing straight into
  // its sums; GL uploads each camera frame once).
  std::vector<FragmentPixels> eye[2];
  std::vector<const DeferredDrawing*> deferred[2];
  for (const ReceivedPiece& piece : pieces) {
    const int e = stereo && piece.f.viewer_id != left_viewer;
    if (piece.deferred)
      deferred[e].push_back(piece.deferred.get());
    else
      eye[e].push_back({&piece.f, piece.pixels()});
  }
  Result r;
  released_ = false;
  cv::Mat& frame = frames_[next_];
  next_ ^= 1;
  cv::Mat right;
  // (Per eye: the two eyes' requests may have taken other frames.)
  for (int e = 0; e < (stereo ? 2 : 1); ++e)
    composite_eye(e, eye[e], deferred[e], width, height, e ? right : frame, r);
  if (stereo) cv::hconcat(frame, right, frame);
  if (!complete && last_.size() == frame.size()) r.filled = Compositor::fill_from(frame, last_);
  last_ = frame;
  r.frame = &frame;
  return r;
}

FrameCompositor::Result FrameCompositor::composite_into(const std::vector<ReceivedPiece>& pieces,
                                                        int width, int height, bool complete,
                                                        cv::Mat& into, const cv::Mat& last) {
  const auto shaped = [&](const cv::Mat& m) {
    return m.rows == height && m.cols == width && m.type() == CV_8UC4 && m.isContinuous();
  };
  if (!shaped(into) || (!last.empty() && !shaped(last)))
    throw std::invalid_argument("FrameCompositor: the frame to resolve into is not " +
                                std::to_string(width) + "x" + std::to_string(height) +
                                " continuous RGBA");
  std::vector<FragmentPixels> frags;
  std::vector<const DeferredDrawing*> deferred;
  for (const ReceivedPiece& piece : pieces)
    if (piece.deferred)
      deferred.push_back(piece.deferred.get());
    else
      frags.push_back({&piece.f, piece.pixels()});
  Result r;
  released_ = false;
  composite_eye(0, frags, deferred, width, height, into, r);
  if (!complete && !last.empty()) r.filled = Compositor::fill_from(into, last);
  last_.release();  // composite() has no last frame after this one
  r.frame = &into;
  return r;
}

bool FrameCompositor::release() {
  if (released_) return false;
  last_.release(), frames_[0].release(), frames_[1].release();
  renderer_->release();
  released_ = true;
  return true;
}

const char* Intake::summary() const {
  switch (verdict) {
    case Verdict::kMalformed:
      return "Dropping a malformed fragment";
    case Verdict::kUnknownCamera:
      return "Dropping a fragment of an unknown camera";
    case Verdict::kNoSize:
      return "No output size: dropping fragments";
    case Verdict::kWrongSize:
      return "Dropping a fragment for another output size";
    case Verdict::kOverBudget:
      return "Dropping requests above max-pixel-rate";
    default:
      return nullptr;
  }
}

std::vector<ReceivedPiece> received_pieces(std::vector<AnswerPiece>&& parts,
                                           const std::shared_ptr<const void>& keep) {
  std::vector<ReceivedPiece> pieces;
  for (AnswerPiece& a : parts) {
    const bool raw = a.encoding == Encoding::kRaw;
    pieces.push_back({std::move(a.f), raw ? a.pixels : nullptr, raw ? keep : nullptr, nullptr});
  }
  return pieces;
}

std::optional<OutputRate::Report> OutputRate::frame(int64_t now_us, bool complete) {
  std::optional<Report> closed;
  if (start_us_ >= 0 && now_us - start_us_ >= kWindowUs) {
    window_.seconds = (now_us - start_us_) / 1e6;
    closed = window_;
    window_ = Report{};
    start_us_ = now_us;
  }
  if (start_us_ < 0) start_us_ = now_us;
  ++window_.frames;
  window_.complete += complete;
  return closed;
}

void ArrivalDeadline::arrived(int64_t age_ns) {
  if (age_ns < 0) return;
  if (ages_.size() < kSamples)
    ages_.push_back(age_ns);
  else
    ages_[next_] = age_ns;
  next_ = (next_ + 1) % kSamples;
}

std::optional<int64_t> ArrivalDeadline::update(int64_t now_ns, int64_t period_ns, int64_t max_ns) {
  if (ages_.size() < kMinSamples || (updated_ns_ != INT64_MIN && now_ns - updated_ns_ < kUpdateNs))
    return std::nullopt;
  std::vector<int64_t> a = ages_;
  const auto q = a.begin() + static_cast<std::ptrdiff_t>((a.size() - 1) * 99 / 100);
  std::nth_element(a.begin(), q, a.end());
  int64_t want = *q + *q / 5;
  want = (want + kStepNs - 1) / kStepNs * kStepNs;
  want = std::clamp(want, period_ns, std::max(period_ns, max_ns));
  if (want == deadline_ || (deadline_ > 0 && want < deadline_ && want * 4 >= deadline_ * 3))
    return std::nullopt;
  deadline_ = want;
  updated_ns_ = now_ns;
  return want;
}

bool FrameBudget::admit(uint64_t sequence, double pixels, double rate, int64_t now_us) {
  if (rate <= 0) return true;
  const auto it = decided_.find(sequence);
  if (it != decided_.end()) return it->second;
  const bool admitted = bucket_.take(rate, now_us, pixels);
  refused_ += !admitted;
  decided_.emplace(sequence, admitted);
  if (decided_.size() > kRemembered) decided_.erase(decided_.begin());
  return admitted;
}

Intake FragmentIntake::take(const uint8_t* data, size_t size, bool check_crc, int w, int h,
                            bool stereo, int64_t now_us) {
  using V = Intake::Verdict;
  Intake in;
  try {
    in.head = peek_fragment_header(data, size);
  } catch (const std::exception& e) {
    in.why = e.what();
    return in;
  }
  const FragmentHeader& head = in.head;
  const bool size_known = w > 0 && h > 0;
  if (!viewer.accepts(head.viewer_id, stereo))
    in.verdict = V::kForeign;
  else if (rig_ && rig_->index_of(static_cast<int>(head.camera_id)) < 0)
    in.verdict = V::kUnknownCamera,
    in.why = "camera " + std::to_string(head.camera_id) + " is not in the rig";
  else if (is_focus_probe(head.sequence) || (is_surface_probe(head.sequence) && size_known))
    in.verdict = V::kProbe;
  else if (!size_known)
    in.verdict = V::kNoSize,
    in.why =
        "set width and height, or send fragment caps with the view's width and height "
        "(lfviewrequest does) (camera " +
        std::to_string(head.camera_id) + ")";
  if (in.verdict != V::kMalformed) return in;
  in.candidate = window.candidate();
  switch (const RequestWindow::Verdict offered = window.offer(head.sequence)) {
    case RequestWindow::Verdict::kAccept:
      break;
    case RequestWindow::Verdict::kFollow:
      in.followed = true;
      break;
    default:
      in.verdict = V::kOutsideWindow;
      in.late = offered == RequestWindow::Verdict::kLate;
      return in;
  }
  const double pixels = static_cast<double>(w) * h;  // one eye: the camera hosts count per viewer
  if (!budget.admit(head.sequence, pixels, max_pixel_rate, now_us)) {
    in.verdict = V::kOverBudget;
    in.why = "request " + std::to_string(head.sequence) + " of viewer " +
             std::to_string(head.viewer_id) + " (" + std::to_string(w) + "x" + std::to_string(h) +
             "): over " + std::to_string(static_cast<uint64_t>(max_pixel_rate)) +
             " output pixels a second; " + std::to_string(budget.refused()) +
             " requests dropped so far";
    return in;
  }
  try {  // all of them together carry at most the frame's pixels
    in.parts = parse_frame_answer(data, size, static_cast<size_t>(w) * h, check_crc);
  } catch (const std::exception& e) {
    in.why = e.what();
    return in;
  }
  const Fragment& f = in.parts.front().f;
  if (f.cameras > 1 && rig_ && f.cameras > rig_->cameras.size()) {
    in.why = "camera " + std::to_string(f.camera_id) + ": a partial sum of " +
             std::to_string(f.cameras) + " cameras, the rig has " +
             std::to_string(rig_->cameras.size());
    return in;
  }
  for (const AnswerPiece& a : in.parts)
    if (a.f.out_width != w || a.f.out_height != h) {
      in.verdict = V::kWrongSize;
      in.why = "camera " + std::to_string(f.camera_id) + ": fragment for " +
               std::to_string(a.f.out_width) + "x" + std::to_string(a.f.out_height) +
               ", the output is " + std::to_string(w) + "x" + std::to_string(h);
      return in;
    }
  in.verdict = V::kAccept;
  return in;
}

}  // namespace lf
