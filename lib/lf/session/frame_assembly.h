// The compositor host's frame assembly (Yang et al. 2002, Section 4.3: the
// compositor collects each view request's fragments and adds them once all
// are in, or at a deadline with whatever arrived): which request sequences
// to take (a window that no single packet can move), the requests waiting
// for their fragments and when each one leaves, the viewer composited, and
// the focus and surface probes being collected.
//
// Plain C++, no GStreamer: lfcompositor and lfpartialsum are the glue
// (pads, buffers, warnings, events). Times are nanoseconds (running times
// and timestamps as GStreamer gives them; kNoTime where there is none) or
// microseconds of a monotonic clock where the name says so. Not
// thread-safe: each element uses its own on its aggregate thread.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace lf {

// No time (GStreamer's GST_CLOCK_TIME_NONE has the same value).
constexpr uint64_t kNoTime = UINT64_MAX;

// The request sequences a compositor takes, handled as RFC 3550 appendix
// A.1 handles RTP sequence numbers, so that no single packet (forged with
// a stream's real SSRC on plain RTP, or stray) can move the window:
//  * accepted: (last emitted, last emitted + kMaxDropout];
//  * late: up to kMaxMisorder behind: dropped and counted;
//  * anything else (a jump ahead, or far behind: a restarted viewer) is on
//    probation: the window moves to it only when a fragment of the very
//    next request (or the one after: one request lost) confirms it.
class RequestWindow {
 public:
  static constexpr uint64_t kMaxDropout = 64;  // requests: 2 s at 30 fps
  static constexpr uint64_t kMaxMisorder = 100;

  enum class Verdict {
    kAccept,     // inside the window
    kLate,       // behind it, dropped (counted in late())
    kProbation,  // outside it: held as the candidate, dropped
    kFollow,     // confirms the candidate: the window moves (drop what waits for the old one)
  };
  Verdict offer(uint64_t seq);
  // Request `seq` left (composited): the window starts after it.
  void emitted(uint64_t seq);
  // Whether `seq` lies inside the window (what offer() accepts without
  // probation): for work done before the window sees a fragment.
  bool inside(uint64_t seq) const { return inside(last_, seq); }
  // The same for a window after `last_emitted` (-1: none), for another
  // thread that reads a published last_emitted().
  static bool inside(int64_t last_emitted, uint64_t seq) {
    return last_emitted < 0 || (seq > static_cast<uint64_t>(last_emitted) &&
                                seq - static_cast<uint64_t>(last_emitted) <= kMaxDropout);
  }
  // The last request emitted (-1: none yet); the probation candidate (-1: none).
  int64_t last_emitted() const { return last_; }
  int64_t candidate() const { return probation_; }
  uint64_t late() const { return late_; }
  void reset() { *this = RequestWindow(); }

 private:
  int64_t last_ = -1;
  int64_t probation_ = -1;
  uint64_t late_ = 0;
};

// The viewer a compositor composites: the one its viewer-id names, or (-1)
// the first one seen; in stereo also the next id (the right eye). Counts
// fragments of other viewers, to warn once when only those come for
// kForeignWarnUs (viewer-id names a viewer that is not there).
class ViewerSelection {
 public:
  static constexpr int64_t kForeignWarnUs = 2'000'000;
  explicit ViewerSelection(int64_t viewer = -1) : viewer_(viewer) {}
  // Whether a fragment of `id` is ours (always true until a viewer is chosen).
  bool accepts(uint32_t id, bool stereo) const {
    return viewer_ < 0 || id == viewer_ || (stereo && id == viewer_ + 1);
  }
  // A fragment of ours was taken: the first one seen chooses the viewer
  // (true then, for the caller to say so).
  bool taken(uint32_t id);
  // A fragment of another viewer at `now_us`: true once, when only such
  // fragments came for kForeignWarnUs.
  bool foreign(int64_t now_us);
  int64_t viewer() const { return viewer_; }
  uint64_t foreign_count() const { return foreign_count_; }
  double foreign_seconds(int64_t now_us) const { return (now_us - foreign_since_us_) / 1e6; }
  // The warning's detail when foreign() said so (`other`: a viewer seen).
  std::string foreign_detail(int64_t now_us, uint32_t other) const;

 private:
  int64_t viewer_;
  uint64_t foreign_count_ = 0;
  int64_t foreign_since_us_ = -1;
  bool warned_ = false;
};

// One request waiting for its fragments: the pieces filed so far, each
// source's (a camera's, or a partial sum's) counted once.
template <class Piece>
struct PendingRequest {
  std::vector<Piece> pieces;
  std::vector<uint64_t> piece_sources;  // the source of each piece
  std::map<uint64_t, size_t> sources;   // source -> cameras it counts (0 once it conflicted)
  size_t count = 0;                     // cameras in all
  bool conflicted = false;              // a source sent twice: never complete
  uint64_t pts = kNoTime, duration = kNoTime;
  uint64_t running_time = kNoTime;  // of its first fragment: its deadline's start
};

// The request sequence of a pending request's key: the sequence itself, or
// (sequence, viewer).
inline uint64_t request_sequence(uint64_t key) {
  return key;
}
inline uint64_t request_sequence(const std::pair<uint64_t, uint32_t>& key) {
  return key.first;
}

// When the requests waiting fall due, whatever their key and pieces (what an
// element's scheduling needs of a PendingRequests).
class RequestTimes {
 public:
  virtual ~RequestTimes() = default;
  // The oldest request waiting: its running time and request sequence;
  // false when none waits.
  virtual bool oldest(uint64_t* running_time, uint64_t* sequence) const = 0;
  // The earliest running time of a waiting request (kNoTime: none): when
  // the next deadline falls.
  virtual uint64_t earliest_running_time() const = 0;
};

// The requests waiting for their fragments, by key (ordered: the request
// sequence first), and the rule by which each leaves: complete (every
// camera counted, no conflict) in order; at its own deadline (or the end of
// stream) incomplete, with what came; the oldest when more than
// `max_pending` wait; live, none behind a newer complete one (shed_stale).
// Each request has its own deadline: one that came late does not take the
// next ones, still in time, with it.
template <class Key, class Piece>
class PendingRequests : public RequestTimes {
 public:
  using Request = PendingRequest<Piece>;
  enum class Added { kAdded, kDuplicate };
  explicit PendingRequests(size_t max_pending = 16) : max_pending_(max_pending) {}

  // Files one source's pieces (its fragment, or a buffer's several) under
  // request `key`, counting `cameras` (a partial sum counts the cameras it
  // holds). A source already filed for the request: nothing is filed
  // (kDuplicate); the caller may then discard() it. The request's times
  // come from its first fragment.
  Added add(const Key& key, uint64_t source, size_t cameras, std::vector<Piece> pieces,
            uint64_t running_time = kNoTime, uint64_t pts = kNoTime, uint64_t duration = kNoTime) {
    Request& r = requests_[key];
    if (!r.sources.emplace(source, cameras).second) return Added::kDuplicate;
    r.count += cameras;
    if (r.pts == kNoTime) r.running_time = running_time, r.pts = pts, r.duration = duration;
    for (Piece& p : pieces) {
      r.pieces.push_back(std::move(p));
      r.piece_sources.push_back(source);
    }
    return Added::kAdded;
  }
  // Drops every piece `source` filed under `key` and marks the request
  // conflicted (a second copy of a camera's fragment: one is forged or
  // stray, and nothing tells which, so neither is used and the frame is
  // never called complete).
  void discard(const Key& key, uint64_t source) {
    auto it = requests_.find(key);
    if (it == requests_.end()) return;
    Request& r = it->second;
    auto s = r.sources.find(source);
    if (s != r.sources.end()) r.count -= std::min(r.count, std::exchange(s->second, 0));
    std::vector<Piece> kept;  // (a piece may move but not be assigned)
    std::vector<uint64_t> kept_sources;
    for (size_t i = 0; i < r.pieces.size(); ++i)
      if (r.piece_sources[i] != source) {
        kept.push_back(std::move(r.pieces[i]));
        kept_sources.push_back(r.piece_sources[i]);
      }
    r.pieces = std::move(kept);
    r.piece_sources = std::move(kept_sources);
    r.conflicted = true;
  }
  // Whether the oldest request leaves now, and whether it is complete.
  // `due(running_time)`: its deadline has passed.
  template <class Due>
  bool front_ready(size_t expected, Due due, bool eos, bool* complete) const {
    if (requests_.empty()) return false;
    const Request& r = requests_.begin()->second;
    *complete = complete_at(r, expected);
    return *complete || eos || requests_.size() > max_pending_ || due(r.running_time);
  }
  // The cameras counted so far for request `key` (0: none waits).
  size_t count_of(const Key& key) const {
    auto it = requests_.find(key);
    return it == requests_.end() ? 0 : it->second.count;
  }
  // Live, when requests come faster than they are composited (the newest
  // request wins, as the camera hosts' lfrequestqueue does): the requests
  // before the newest complete one are dropped, so that one is composited
  // next instead of each older one in turn behind it. Counted in shed().
  void shed_stale(size_t expected) {
    auto newest = requests_.end();
    for (auto it = requests_.begin(); it != requests_.end(); ++it)
      if (complete_at(it->second, expected)) newest = it;
    if (newest == requests_.end()) return;
    shed_ += static_cast<uint64_t>(std::distance(requests_.begin(), newest));
    requests_.erase(requests_.begin(), newest);
  }
  uint64_t shed() const { return shed_; }  // requests shed_stale() dropped so far
  // Every camera counted, and no conflict.
  static bool complete_at(const Request& r, size_t expected) {
    return r.count >= expected && !r.conflicted;
  }
  const Key& front_key() const { return requests_.begin()->first; }
  Request& front() { return requests_.begin()->second; }
  void pop_front() { requests_.erase(requests_.begin()); }
  uint64_t earliest_running_time() const override {
    uint64_t t = kNoTime;
    for (const auto& [k, r] : requests_) t = std::min(t, r.running_time);
    return t;
  }
  bool oldest(uint64_t* running_time, uint64_t* sequence) const override {
    if (requests_.empty()) return false;
    *running_time = requests_.begin()->second.running_time;
    *sequence = request_sequence(requests_.begin()->first);
    return true;
  }
  bool empty() const { return requests_.empty(); }
  size_t size() const { return requests_.size(); }
  void clear() { requests_.clear(); }

 private:
  std::map<Key, Request> requests_;
  size_t max_pending_;
  uint64_t shed_ = 0;
};

// Probes of one kind being collected (lib/lf/focus/focus_probe.h answers, or
// lib/lf/focus/surface_probe.h ones), by id: at most `max_open` at once (beyond,
// the one started first is scored with what came), and the ids of the last
// kRemembered scored, so that late fragments of a probe do not start it
// again (by id, not by order: a peer's id must not make later probes look
// stale).
template <class Answers>
class ProbeCollector {
 public:
  static constexpr size_t kRemembered = 16;
  struct Probe {
    uint32_t id = 0;
    uint32_t viewer = 0;
    int64_t started_us = 0;
    Answers answers;
  };
  using Iter = typename std::map<uint32_t, Probe>::iterator;

  explicit ProbeCollector(size_t max_open) : max_open_(max_open) {}
  bool scored(uint32_t id) const {
    return std::find(finished_.begin(), finished_.end(), id) != finished_.end();
  }
  Iter find(uint32_t id) { return open_.find(id); }
  Iter end() { return open_.end(); }
  // Whether a new probe must wait until the oldest one is scored.
  bool full() const { return open_.size() >= max_open_; }
  Iter open(Probe p) {
    const uint32_t id = p.id;
    return open_.emplace(id, std::move(p)).first;
  }
  // Takes probe `it` out of the open ones, to be scored.
  Probe take(Iter it) {
    Probe p = std::move(it->second);
    open_.erase(it);
    finished_.push_back(p.id);
    if (finished_.size() > kRemembered) finished_.pop_front();
    return p;
  }
  Iter oldest() {
    return std::min_element(open_.begin(), open_.end(), [](const auto& a, const auto& b) {
      return a.second.started_us < b.second.started_us;
    });
  }
  // The open probes started more than `deadline_us` before `now_us`.
  std::vector<uint32_t> expired(int64_t now_us, int64_t deadline_us) const {
    std::vector<uint32_t> ids;
    for (const auto& [id, p] : open_)
      if (now_us - p.started_us > deadline_us) ids.push_back(id);
    return ids;
  }
  size_t size() const { return open_.size(); }

 private:
  std::map<uint32_t, Probe> open_;
  std::deque<uint32_t> finished_;
  size_t max_open_;
};

}  // namespace lf
