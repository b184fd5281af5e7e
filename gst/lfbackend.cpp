#include "lfbackend.h"

#include <deque>
#include <mutex>

namespace lfgst {

GstEvent* shared_fragment_caps_event(const GstCaps* in, FragmentEncoding enc) {
  struct Entry {
    GstCaps* in;
    FragmentEncoding enc;
    GstEvent* out;
  };
  // The newest last, at most kCaps; its references dropped at exit.
  struct Cache {
    std::mutex m;
    std::deque<Entry> entries;
    void drop_front() {
      gst_caps_unref(entries.front().in);
      gst_event_unref(entries.front().out);
      entries.pop_front();
    }
    ~Cache() {
      while (!entries.empty()) drop_front();
    }
  };
  constexpr size_t kCaps = 8;
  static Cache cache;
  std::lock_guard<std::mutex> lock(cache.m);
  for (const Entry& e : cache.entries)
    if (e.enc == enc && gst_caps_is_equal(e.in, in)) return gst_event_ref(e.out);
  GstCaps* caps = fragment_caps(enc, in);
  cache.entries.push_back({gst_caps_copy(in), enc, gst_event_new_caps(caps)});
  gst_caps_unref(caps);
  if (cache.entries.size() > kCaps) cache.drop_front();
  return gst_event_ref(cache.entries.back().out);
}

}  // namespace lfgst
