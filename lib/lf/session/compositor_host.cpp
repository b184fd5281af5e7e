#include "lf/session/compositor_host.h"

#include <opencv2/core.hpp>

#include "lf/render/composite.h"

namespace lf {

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
  cv::Mat& frame = frames_[next_];
  next_ ^= 1;
  cv::Mat right;
  for (int e = 0; e < (stereo ? 2 : 1); ++e) {
    std::vector<SlotDrawing> drawings;
    // (Per eye: the two eyes' requests may have taken other frames.)
    for (const DeferredDrawing* d : deferred[e]) {
      renderer_->set_image(d->slot, d->image, d->frame_key, d->frame_pts);
      drawings.push_back({&d->plan, &d->camera, d->slot});
    }
    for (auto& [i, why] :
         renderer_->composite(e, width, height, eye[e], drawings, e ? right : frame))
      r.refused.emplace_back(i < eye[e].size() ? static_cast<int>(eye[e][i].fragment->camera_id)
                                               : drawings[i - eye[e].size()].camera->id,
                             std::move(why));
  }
  if (stereo) cv::hconcat(frame, right, frame);
  if (!complete && last_.size() == frame.size()) r.filled = Compositor::fill_from(frame, last_);
  last_ = frame;
  r.frame = &frame;
  return r;
}

}  // namespace lf
