// Live load shedding for view requests: a bounded queue that keeps, for
// each key (a viewer's frame requests, or its probes), only the requests
// within `max_age` of that key's newest (0: the newest alone: "the newest
// request wins"), and serves the keys in turn (round robin, in key order),
// each key's oldest kept request first. So a host that cannot keep up
// answers each viewer's newest work instead of working through stale
// requests (latency bounded by the age, not by the backlog), and one
// viewer's flood takes its own turn only, never another viewer's.
//
// Plain C++, no GStreamer: the lfrequestqueue element is its glue. Times
// are the requests' own (their PTS, ns; the caller gives arrival time when
// they have none). Not thread-safe: the caller locks.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <iterator>
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
  std::vector<T> push(uint64_t key, uint64_t time_ns, T value) {
    std::vector<T> dropped;
    std::deque<Item>& q = keys_[key];
    q.push_back({time_ns, std::move(value)});
    ++size_;
    // Stale: behind a newer request of the same key by more than the age.
    while (q.size() > 1 && (max_age_ == 0 || q.front().time + max_age_ < time_ns)) {
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

  // The next request in turn (the caller checks !empty()): the first key
  // after the one served last, wrapping, and its oldest request.
  T pop() {
    auto it = served_any_ ? keys_.upper_bound(last_) : keys_.begin();
    if (it == keys_.end()) it = keys_.begin();
    last_ = it->first;
    served_any_ = true;
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
    size_ = 0;
    served_any_ = false;
    return all;
  }

 private:
  struct Item {
    uint64_t time;
    T value;
  };
  size_t capacity_;
  uint64_t max_age_;
  std::map<uint64_t, std::deque<Item>> keys_;
  size_t size_ = 0;
  uint64_t last_ = 0;
  bool served_any_ = false;
};

}  // namespace lf
