// The compositor host's frames (Yang et al. 2002, Section 4.3: the
// fragments of a view request added into the output frame, renormalised by
// the accumulated weight): what it keeps of each camera's answer until the
// request leaves, and the frame it makes of them with its renderer, the
// two eyes of a stereo pair side by side, and where a request left
// incomplete (a missed deadline) has no weight, the last frame's pixels
// instead of black.
//
// Plain C++, no GStreamer: lfcompositor is the glue. Not thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lf/geometry/rig.h"
#include "lf/render/fragment.h"
#include "lf/render/renderer.h"
#include "lf/session/frame_assembly.h"
#include "lf/session/rate_limit.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/wire.h"

namespace lf {

// A piece of a camera's answer kept until its request is composited: a
// fragment (raw pixels in place in what was received, or decoded into
// f.pixels), or an empty one whose drawing was left to the compositor.
struct ReceivedPiece {
  Fragment f;
  const uint8_t* raw_pixels = nullptr;  // in place, kept valid by `keep`
  std::shared_ptr<const void> keep;     // what holds raw_pixels (a mapped buffer), or null
  std::shared_ptr<const DeferredDrawing> deferred;
  const uint8_t* pixels() const { return raw_pixels ? raw_pixels : f.pixels.data(); }
};

class FrameCompositor {
 public:
  explicit FrameCompositor(std::unique_ptr<Renderer> renderer) : renderer_(std::move(renderer)) {}
  struct Result {
    const cv::Mat* frame = nullptr;                    // CV_8UC4, valid until the next composite()
    size_t filled = 0;                                 // pixels taken from the last frame
    std::vector<std::pair<int, std::string>> refused;  // (camera id, why) left out
  };
  // One request's frame from its pieces: width x height, or with `stereo`
  // 2 width x height, the pieces of viewer `left_viewer` on the left and
  // the others on the right. An incomplete request (`complete` false) takes
  // the last frame's pixels where no weight arrived. Pieces the renderer
  // refuses are left out and named. Throws what the renderer throws
  // (std::invalid_argument, std::runtime_error).
  Result composite(const std::vector<ReceivedPiece>& pieces, int width, int height, bool stereo,
                   uint32_t left_viewer, bool complete);
  // The same for one eye, resolved straight into `into` (height x width,
  // CV_8UC4, continuous: e.g. an output buffer mapped for writing, so the
  // frame is not copied again), the missing pixels of an incomplete request
  // taken from `last` (the last frame sent; empty for none). The frames
  // this object keeps are not used. Result::frame is `&into`. Throws
  // std::invalid_argument where `into` or a non-empty `last` is not of that
  // shape, else what composite() throws.
  Result composite_into(const std::vector<ReceivedPiece>& pieces, int width, int height,
                        bool complete, cv::Mat& into, const cv::Mat& last);
  Renderer& renderer() { return *renderer_; }
  // Frees the frames and the renderer's sums (its viewer went quiet, or the
  // stream ended: at 3840x2160 its frames are 33 MB each, and the sums that
  // a surface of two layers keeps 133 MB more); the next
  // composite() allocates them again, its missing pixels black (no last
  // frame). False when nothing was held (freed already, or never used).
  bool release();
  bool holds_memory() const { return !released_; }

 private:
  // One eye's fragments and drawings resolved into `into`; refusals into `r`.
  void composite_eye(int eye, const std::vector<FragmentPixels>& frags,
                     const std::vector<const DeferredDrawing*>& deferred, int width, int height,
                     cv::Mat& into, Result& r);
  std::unique_ptr<Renderer> renderer_;
  cv::Mat last_;       // the last frame (missing pixels come from it)
  cv::Mat frames_[2];  // the frames resolved into, in turn (one is last_): no allocation per frame
  int next_ = 0;
  bool released_ = true;  // nothing held since the last release (or ever)
};

// What the compositor host does with a fragment buffer (a peer's bytes)
// before anything is decoded: its header is checked against the viewer
// composited (lf::ViewerSelection), the rig's cameras, the output size and
// the request window (lf::RequestWindow, RFC 3550 A.1); then the camera's
// answer is parsed (lf::parse_frame_answer) with the frame's area as its
// pixel limit, and a partial sum may not hold more cameras than the rig.
struct Intake {
  enum class Verdict {
    kAccept,         // `parts`: the camera's answer, to file under its request
    kProbe,          // a focus or surface probe's answer, to score (lf::ProbeScoring)
    kMalformed,      // `why`
    kForeign,        // another viewer's fragment (not an error)
    kUnknownCamera,  // a camera the rig does not have
    kNoSize,         // no output size is known yet
    kOutsideWindow,  // outside the request window (late, or on probation)
    kWrongSize,      // for another output size (`why`)
    kOverBudget,     // a request over the pixel budget (`why`; lf::FrameBudget)
  } verdict = Verdict::kMalformed;
  FragmentHeader head;
  std::vector<AnswerPiece> parts;
  std::string why;
  // Accepted by moving the window (a restarted viewer, or requests lost for
  // a while): what waits for the old window is to be dropped. `candidate`:
  // the sequence the window held on probation.
  bool followed = false;
  int64_t candidate = -1;
  bool late = false;  // kOutsideWindow: behind the window (a request already emitted)
  // A warning's title for a dropped fragment (`why` its detail); null for
  // kAccept, kProbe, kForeign and kOutsideWindow (not warned about).
  const char* summary() const;
};

// The pieces a camera's answer gives (`parts`, lf::parse_frame_answer): raw
// pixels in place, in what was received (`keep` holds it), decoded ones
// moved.
std::vector<ReceivedPiece> received_pieces(std::vector<AnswerPiece>&& parts,
                                           const std::shared_ptr<const void>& keep);

// The compositor host's pixel budget for its viewer (lfcompositor
// max-pixel-rate): output pixels a second of the requests it composites, in
// the camera hosts' unit (lffragment max-pixel-rate, a token bucket with a
// second's burst). A request is admitted or refused whole, at its first
// fragment, and the later fragments of a refused request are refused
// unparsed: a flood the camera hosts let through (their budgets raised, or
// packets forged on plain RTP) costs the compositor host at most its budget,
// and it never composites half a frame.
class FrameBudget {
 public:
  static constexpr size_t kRemembered = 256;  // requests whose decision is kept
  // Whether request `sequence` (an output of `pixels` pixels) is composited,
  // at `rate` output pixels a second (0: no limit) at `now_us`.
  bool admit(uint64_t sequence, double pixels, double rate, int64_t now_us);
  uint64_t refused() const { return refused_; }  // requests refused so far

 private:
  TokenBucket bucket_;
  std::map<uint64_t, bool> decided_;  // sequence -> admitted
  uint64_t refused_ = 0;
};

// The rate a compositor host achieves (what a viewer gets when the hosts
// cannot keep the rate it asks for): the frames composited, and how many of
// them complete (every camera's fragment in by the deadline), over windows
// of kWindowUs; one report a window.
class OutputRate {
 public:
  static constexpr int64_t kWindowUs = 1'000'000;
  struct Report {
    double seconds = 0;                 // the window's length
    uint64_t frames = 0, complete = 0;  // composited in it, of them complete
    double fps() const { return seconds > 0 ? frames / seconds : 0; }
    double complete_fps() const { return seconds > 0 ? complete / seconds : 0; }
  };
  // A frame composited at `now_us`; the report of the window it closes, if
  // it closes one (the first frame opens the first window).
  std::optional<Report> frame(int64_t now_us, bool complete);

 private:
  int64_t start_us_ = -1;
  Report window_;
};

// The compositor host's deadline from what it sees: how long after a
// request's time (its running time) the fragments of its requests arrive,
// so that a host whose cameras take longer than a request period (1080p
// JPEG on 2 cores: 60-250 ms through 64 cameras) composites complete frames
// instead of frames short of the slow cameras (what a fixed deadline of one
// period, Yang et al. 2002 4.3, gives). Ages of the fragments used or late
// (not probes, not the ones refused) go in; the deadline is their 99th
// percentile over the last kSamples, plus a fifth, rounded up to kStepNs,
// never under the request period nor over the cap. It rises as soon as the
// ages need it and falls only under three quarters of itself, at most once
// a kUpdateNs (each change re-configures the pipeline's latency).
class ArrivalDeadline {
 public:
  static constexpr size_t kSamples = 2048, kMinSamples = 64;
  static constexpr int64_t kStepNs = 5'000'000, kUpdateNs = 1'000'000'000;
  // A fragment that arrived `age_ns` after its request's time (negative:
  // unknown, ignored).
  void arrived(int64_t age_ns);
  // The deadline at `now_ns` for requests every `period_ns`, at most
  // `max_ns` (>= period_ns): the new value when it changes, else none.
  std::optional<int64_t> update(int64_t now_ns, int64_t period_ns, int64_t max_ns);
  int64_t deadline() const { return deadline_; }  // 0 before the first update

 private:
  std::vector<int64_t> ages_;  // a ring of kSamples
  size_t next_ = 0;
  int64_t deadline_ = 0, updated_ns_ = INT64_MIN;
};

class FragmentIntake {
 public:
  // `rig` may be null (no rig: any camera id).
  FragmentIntake(std::shared_ptr<const Rig> rig, int64_t viewer)
      : viewer(viewer), rig_(std::move(rig)) {}
  // A buffer's fragment(s), for a view of width x height (0: unknown; the
  // output is twice as wide with `stereo`); `check_crc` false only for
  // bytes that never left this process; at `now_us` (the budget's clock).
  // Never throws.
  Intake take(const uint8_t* data, size_t size, bool check_crc, int width, int height, bool stereo,
              int64_t now_us);

  ViewerSelection viewer;     // the viewer composited
  RequestWindow window;       // the request sequences accepted
  FrameBudget budget;         // the requests composited, at max_pixel_rate
  double max_pixel_rate = 0;  // output pixels a second (0: no limit; not live: 0)
 private:
  std::shared_ptr<const Rig> rig_;
};

}  // namespace lf
