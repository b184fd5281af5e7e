// The camera host's frames (the paper's random access camera, Yang et al.
// 2002, Section 4.2: a request is answered from the camera's current
// frame): the last few frames of one camera with their capture times, which
// frame answers a request, and the waits between the camera's thread and
// the request thread.
//
// Plain C++ (a template over the frame handle), no GStreamer: lffragment is
// the glue. Thread-safe: the camera thread calls push() and the end/flush
// calls, the request thread pick(); every call takes the object's lock.
// Times are nanoseconds (capture times and request times on one clock, e.g.
// a pipeline's running time; -1 unknown); timeouts are on std::chrono's
// steady clock.
//
//  * Live cameras never wait for requests; a request waits for a frame at
//    most the timeout, so a camera that never delivers cannot hold it.
//  * A camera known not to be live (a file, a still repeated) has no
//    deadline once its format is known (set_camera): a request waits for
//    its frame as long as it takes (as GstAggregator waits without a
//    latency); before (the camera still starting: set_live), kStarting
//    timeouts, so one that never starts cannot hold the requests for
//    ever. The camera is held once it
//    is kAhead frames ahead of the requests, unless a request waits for a
//    frame it has not made yet: it then makes about one frame a request
//    instead of as many as the CPU allows (64 still cameras took 37 s for
//    60 requests of one viewer before).
//  * By capture time: the newest frame captured at or before the request's
//    time, once that frame is known to be the one (a later frame came, or
//    one within a frame period before the time).
//  * A probe's steps (lib/lf/focus/focus_probe.h, surface_probe.h) all take
//    the frame that its first step took, even after newer frames pushed it
//    out; a live camera that no longer holds the frame of a probe's instant,
//    or skipped it, has none (it sits the probe out).
#pragma once

#include <chrono>
#include <climits>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <utility>

namespace lf {

// Frame: a copyable handle (e.g. a reference to a buffer); a
// default-constructed one is "no frame" and converts to false.
template <class Frame>
class CameraFrames {
 public:
  static constexpr int kAhead = 2;
  static constexpr int kStarting = 10;  // timeouts a non-live camera has to start

  // Frames kept: `keep` (at least 1).
  explicit CameraFrames(size_t keep = 2) : keep_(keep < 1 ? 1 : keep) {}

  // Set when the camera's format is known: whether it is live (1), not (0)
  // or unknown (-1), and its frame period (ns; <= 0 unknown).
  void set_camera(int live, int64_t period_ns) {
    std::lock_guard<std::mutex> l(m_);
    live_ = live, period_ = period_ns, started_ = true;
  }
  // Liveness alone (learnt before the format: the frame period stays).
  void set_live(int live) {
    set([&] { live_ = live; });
  }
  int live() const {
    std::lock_guard<std::mutex> l(m_);
    return live_;
  }
  void set_keep(size_t keep) {
    std::lock_guard<std::mutex> l(m_);
    keep_ = keep < 1 ? 1 : keep;
  }

  // Camera thread: a frame captured at `capture_ns`. Returns once it is
  // kept and, for a camera not live, once the requests need more frames;
  // kFlushing (not kept) while flushing, kEnd once the requests ended.
  enum class Pushed { kOk, kFlushing, kEnd };
  Pushed push(int64_t capture_ns, Frame f) {
    std::unique_lock<std::mutex> l(m_);
    if (flushing_) return Pushed::kFlushing;
    ring_.emplace_back(capture_ns, std::move(f));
    while (ring_.size() > keep_) ring_.pop_front();
    cv_.notify_all();
    ++ahead_;
    cv_.wait(l, [&] {
      return live_ != 0 || ahead_ < kAhead || (waiting_ > 0 && !wanted_is_here()) || flushing_ ||
             requests_ended_;
    });
    return requests_ended_ ? Pushed::kEnd : Pushed::kOk;
  }
  // The camera's stream ended: its newest frame stands for every later
  // instant (a still, or a camera that stopped).
  void camera_ended() {
    set([this] { camera_ended_ = true; });
  }
  // Every request is answered: a held camera goes on, to its end.
  void requests_ended() {
    set([this] { requests_ended_ = true; });
  }
  // Flushing wakes every wait (pick returns flushing) and refuses frames.
  void set_flushing(bool f) {
    set([&] { flushing_ = f; });
  }
  // The end of a flush: the requests go on (their end is forgotten), and
  // from the camera's side (`camera`) so does the camera.
  void flush_stop(bool camera) {
    set([&] {
      flushing_ = requests_ended_ = false;
      if (camera) camera_ended_ = false;
    });
  }
  // Back to the start (no frames, nothing known of the camera).
  void reset() {
    set([this] {
      ring_.clear();
      probe_frame_ = Frame();
      camera_ended_ = requests_ended_ = false;
      live_ = -1, period_ = -1, started_ = false;
      ahead_ = waiting_ = 0;
    });
  }

  // What a request asks for.
  struct Want {
    int64_t time_ns = -1;           // the request's time (-1: unknown: the newest)
    bool by_capture_time = false;   // else the newest
    std::optional<uint64_t> probe;  // a probe's key (its steps share a frame)
  };
  struct Pick {
    Frame frame;            // none: no frame (timed out, or a probe sat out)
    bool flushing = false;  // interrupted: the request is dropped
  };
  // Request thread: the frame for `w`, waiting for the camera at most
  // `timeout` (a camera not live: without limit).
  Pick pick(const Want& w, std::chrono::nanoseconds timeout) {
    std::unique_lock<std::mutex> l(m_);
    const auto deadline = std::chrono::steady_clock::now() +
                          (live_ == 0 && !started_ ? kStarting * timeout : timeout);
    Pick out;
    while (ring_.empty() && !flushing_ && !camera_ended_)
      if (!wait(l, deadline, kAnyFrame)) break;
    if (flushing_) {
      out.flushing = true;
      return out;
    }
    if (w.probe && probe_frame_ && probe_key_ == *w.probe) {
      out.frame = probe_frame_;
    } else if ((w.by_capture_time || w.probe) && w.time_ns >= 0) {
      out.frame = at(l, deadline, w.time_ns, w.probe && live_ != 0);
      if (w.probe && out.frame) probe_key_ = *w.probe, probe_frame_ = out.frame;
    } else if (!ring_.empty()) {
      out.frame = ring_.back().second;
    }
    out.flushing = flushing_;
    if (out.frame) {  // a frame taken: a camera held for being ahead may make the next
      ahead_ = 0;
      cv_.notify_all();
    }
    return out;
  }

 private:
  static constexpr int64_t kAnyFrame = INT64_MIN;

  template <class F>
  void set(F&& f) {
    std::lock_guard<std::mutex> l(m_);
    f();
    cv_.notify_all();
  }
  bool wanted_is_here() const {
    return !ring_.empty() && (want_ == kAnyFrame || ring_.back().first > want_);
  }
  // Waits (lock held) until woken or the deadline (none for a camera not
  // live) for a frame captured after `want`; false when the deadline passed.
  // A camera held for being ahead goes on meanwhile, until it has made one.
  bool wait(std::unique_lock<std::mutex>& l, std::chrono::steady_clock::time_point deadline,
            int64_t want) {
    want_ = want;
    if (waiting_++ == 0) cv_.notify_all();
    bool woken = true;
    if (live_ == 0 && started_)
      cv_.wait(l);
    else
      woken = cv_.wait_until(l, deadline) == std::cv_status::no_timeout;
    --waiting_;
    return woken;
  }
  // By capture time (lock held): waits until the frame for `t` is known,
  // then the newest at or before t, or when all are later (a request older
  // than the ring) the oldest kept. With `exact`, only a frame of t's own
  // tick (captured within a frame period before t; after the camera's end,
  // its last frame).
  Frame at(std::unique_lock<std::mutex>& l, std::chrono::steady_clock::time_point deadline,
           int64_t t, bool exact) {
    const auto settled = [&] {
      if (ring_.empty()) return false;
      const int64_t newest = ring_.back().first;
      return newest > t || (period_ > 0 && newest > t - period_);
    };
    while (!settled() && !flushing_ && !camera_ended_)
      if (!wait(l, deadline, period_ > 0 ? t - period_ : t)) break;
    if (ring_.empty() || (exact && ring_.front().first > t)) return Frame();
    const std::pair<int64_t, Frame>* best = &ring_.front();
    for (const auto& f : ring_)
      if (f.first <= t) best = &f;
    if (exact && period_ > 0 && best->first <= t - period_ && !camera_ended_) return Frame();
    return best->second;
  }

  mutable std::mutex m_;
  std::condition_variable cv_;
  size_t keep_;
  std::deque<std::pair<int64_t, Frame>> ring_;  // oldest first
  uint64_t probe_key_ = 0;
  Frame probe_frame_;
  int live_ = -1;
  bool started_ = false;  // the format is known (set_camera)
  int64_t period_ = -1;
  bool flushing_ = false, camera_ended_ = false, requests_ended_ = false;
  int ahead_ = 0;    // frames since a request last took one
  int waiting_ = 0;  // requests waiting for a frame
  int64_t want_ = kAnyFrame;
};

}  // namespace lf
