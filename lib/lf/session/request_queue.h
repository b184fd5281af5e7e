// Live load shedding for view requests: a bounded queue that keeps, for
// each key (a viewer's frame requests, or its probes), only the requests
// within `max_age` of that key's newest (0: the newest alone: "the newest
// request wins", unless another viewer's requests held it: see push()),
// and serves the keys in turns weighted by what their requests cost (a
// request's cost: its output pixels), each key's oldest kept request
// first: the key served least, in cost, goes next (start-time fair
// queueing: a key's tag is the cost served to it, never below the virtual
// time, the tag of the last request served, so a key that was idle has no
// credit saved up); keys of equal tags take turns in key order. So a host
// that cannot keep up answers each viewer's newest work instead of working
// through stale requests (latency bounded by the age, not by the backlog),
// and one viewer's flood of large views takes its own share, never another
// viewer's: a viewer of small views goes first.
//
// Plain C++, no GStreamer: the lfrequestqueue element is its glue. Times
// are the requests' own (their PTS, ns; the caller gives arrival time when
// they have none). Not thread-safe: the caller locks.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <iterator>
#include <limits>
#include <map>
#include <utility>
#include <vector>

namespace lf {

template <typename T>
class RequestQueue {
 public:
  // At most `capacity` requests wait in all (>= 1); a key's request older
  // than its newest by more than `max_age_ns` is dropped (0: all older).
  explicit RequestQueue(size_t capacity = 64, uint64_t max_age_ns = 0)
      : capacity_(capacity ? capacity : 1), max_age_(max_age_ns) {}

  // Queues `value` under `key` at `time_ns`; returns what it displaced
  // (stale requests of the same key, then the oldest request of the
  // longest queue while over capacity), for the caller to release.
  // `cost` (> 0) is what serving it takes, e.g. its output pixels.
  std::vector<T> push(uint64_t key, uint64_t time_ns, T value, double cost = 1) {
    std::vector<T> dropped;
    std::deque<Item>& q = keys_[key];
    q.push_back({time_ns, cost > 0 ? cost : 1, std::move(value)});
    ++size_;
    // Stale: behind a newer request of the same key by more than the age.
    // With age 0, a key not over its share (its tag at most the other
    // viewers': served no more than they were, by cost) while another
    // viewer's requests wait, or while another viewer was served within the
    // last second (its work may hold the cameras now), keeps up to kHeld:
    // what held them was that viewer's work, not its own backlog (a 640x480
    // viewer's requests that came while a 3840x2160 one held the cameras).
    // A viewer alone keeps only its newest.
    size_t keep = SIZE_MAX;  // with an age, the age alone
    if (max_age_ == 0)
      keep = under_share(key) && (other_viewer_waiting(key) || other_viewer_served(key, time_ns))
                 ? kHeld
                 : 1;
    while (q.size() > keep ||
           (q.size() > 1 && max_age_ > 0 && q.front().time + max_age_ < time_ns)) {
      dropped.push_back(std::move(q.front().value));
      q.pop_front();
      --size_;
    }
    while (size_ > capacity_) {
      auto longest = keys_.begin();
      for (auto it = keys_.begin(); it != keys_.end(); ++it)
        if (it->second.size() > longest->second.size()) longest = it;
      dropped.push_back(std::move(longest->second.front().value));
      longest->second.pop_front();
      --size_;
      if (longest->second.empty()) keys_.erase(longest);
    }
    return dropped;
  }

  bool empty() const { return size_ == 0; }
  size_t size() const { return size_; }

  // The next request in turn (the caller checks !empty()): the oldest
  // request of the key of the lowest tag, among equal ones the first key
  // after the one served last, wrapping.
  T pop() {
    auto first = served_any_ ? keys_.upper_bound(last_) : keys_.begin();
    if (first == keys_.end()) first = keys_.begin();
    auto it = first;
    double lowest = tag(it->first);
    for (auto k = std::next(first);; ++k) {
      if (k == keys_.end()) k = keys_.begin();
      if (k == first) break;
      if (const double t = tag(k->first); t < lowest) lowest = t, it = k;
    }
    vtime_ = lowest;
    tags_[it->first] = lowest + it->second.front().cost;
    // Tags at or below the virtual time say nothing (a key starts there):
    // dropped, and at most kTags kept (the lowest goes: one tag is added a pop).
    for (auto t = tags_.begin(); t != tags_.end();)
      t = t->second <= vtime_ ? tags_.erase(t) : std::next(t);
    erase_lowest_over(tags_, kTags);
    last_ = it->first;
    served_any_ = true;
    // When each viewer was last served (at most kTags viewers: the oldest goes).
    served_at_[it->first >> 1] = it->second.front().time;
    erase_lowest_over(served_at_, kTags);
    T value = std::move(it->second.front().value);
    it->second.pop_front();
    --size_;
    if (it->second.empty()) keys_.erase(it);
    return value;
  }

  // Everything queued, oldest key first (for the caller to release).
  std::vector<T> clear() {
    std::vector<T> all;
    for (auto& [key, q] : keys_)
      for (Item& i : q) all.push_back(std::move(i.value));
    keys_.clear();
    tags_.clear();
    size_ = 0;
    vtime_ = 0;
    served_any_ = false;
    served_at_.clear();
    return all;
  }

 private:
  static constexpr size_t kTags = 256;               // keys whose served cost is remembered
  static constexpr size_t kHeld = 3;                 // requests a key under its share keeps (age 0)
  static constexpr uint64_t kRecentNs = 1000000000;  // "served within the last second"
  // Whether a key of another viewer (keys: viewer << 1 | probe) has
  // requests waiting.
  bool other_viewer_waiting(uint64_t key) const {
    for (const auto& [k, q] : keys_)
      if ((k >> 1) != (key >> 1) && !q.empty()) return true;
    return false;
  }
  // Whether `key` has been served no more than the other viewers: its tag
  // at most the lowest other viewer's tag kept (those are above the virtual
  // time), or at the virtual time when no other viewer has one.
  bool under_share(uint64_t key) const {
    double others = std::numeric_limits<double>::infinity();
    for (const auto& [k, t] : tags_)
      if ((k >> 1) != (key >> 1)) others = std::min(others, t);
    return tag(key) <= (std::isinf(others) ? vtime_ : others);
  }
  // Erases the entry of the lowest value while `m` has more than `n`.
  template <typename M>
  static void erase_lowest_over(M& m, size_t n) {
    while (m.size() > n)
      m.erase(std::min_element(m.begin(), m.end(),
                               [](const auto& a, const auto& b) { return a.second < b.second; }));
  }
  // Whether another viewer's request (by its time) was served within
  // kRecentNs of `time_ns`.
  bool other_viewer_served(uint64_t key, uint64_t time_ns) const {
    for (const auto& [viewer, t] : served_at_)
      if (viewer != (key >> 1) && t + kRecentNs >= time_ns) return true;
    return false;
  }
  struct Item {
    uint64_t time;
    double cost;
    T value;
  };
  double tag(uint64_t key) const {
    const auto t = tags_.find(key);
    return t != tags_.end() && t->second > vtime_ ? t->second : vtime_;
  }
  size_t capacity_;
  uint64_t max_age_;
  std::map<uint64_t, std::deque<Item>> keys_;
  std::map<uint64_t, double> tags_;         // cost served, beyond vtime_
  std::map<uint64_t, uint64_t> served_at_;  // viewer -> time of its last request served
  double vtime_ = 0;
  size_t size_ = 0;
  uint64_t last_ = 0;
  bool served_any_ = false;
};

}  // namespace lf
