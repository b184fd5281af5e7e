#include "lfmemory.h"

#include <glib.h>
#include <sys/mman.h>

#include <atomic>
#include <deque>
#include <iterator>
#include <mutex>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace lfgst {

void trim_heap() {
  release_buffers();
#if defined(__GLIBC__)
  static std::atomic<gint64> last_us{0};
  const gint64 now = g_get_monotonic_time();
  gint64 last = last_us.load();
  if (now - last < G_USEC_PER_SEC || !last_us.compare_exchange_strong(last, now)) return;
  malloc_trim(0);
#endif
}

namespace {
// Mappings of buffers gone, kept a while for the next buffers of their size
// (a fresh mapping costs a page fault per 4 KiB written), oldest first.
struct Mapping {
  void* data;
  gsize size;
  gint64 idle_since_us;
};
std::mutex cache_lock;
std::deque<Mapping> cache;
std::atomic<gsize> cached_bytes{0};
constexpr gsize kCacheBytes = 256 << 20;
constexpr gint64 kIdleUs = G_USEC_PER_SEC;

// Unmaps the cached mappings idle since before `until_us` (all: G_MAXINT64),
// and the oldest beyond kCacheBytes. Under cache_lock.
void expire(gint64 until_us) {
  while (!cache.empty() &&
         (cache.front().idle_since_us < until_us || cached_bytes.load() > kCacheBytes)) {
    munmap(cache.front().data, cache.front().size);
    cached_bytes -= cache.front().size;
    cache.pop_front();
  }
}

void give_back(gpointer m) {
  auto* mapping = static_cast<Mapping*>(m);
  const gint64 now = g_get_monotonic_time();
  std::lock_guard<std::mutex> hold(cache_lock);
  cache.push_back({mapping->data, mapping->size, now});
  cached_bytes += mapping->size;
  expire(now - kIdleUs);
  delete mapping;
}
}  // namespace

GstBuffer* new_buffer(gsize size) {
  const bool own = size >= kOwnMappingBytes;
  const gsize mapped = (size + kOwnMappingBytes - 1) / kOwnMappingBytes * kOwnMappingBytes;
  void* data = nullptr;
  if (own || cached_bytes.load() > 0) {  // expiry, then a mapping of this size if kept
    std::lock_guard<std::mutex> hold(cache_lock);
    expire(g_get_monotonic_time() - kIdleUs);
    for (auto it = cache.rbegin(); own && it != cache.rend(); ++it)
      if (it->size == mapped) {
        data = it->data;
        cached_bytes -= mapped;
        cache.erase(std::next(it).base());
        break;
      }
  }
  if (!own) return gst_buffer_new_allocate(nullptr, size, nullptr);
  if (!data)
    data = mmap(nullptr, mapped, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (data == MAP_FAILED) return nullptr;
  return gst_buffer_new_wrapped_full(static_cast<GstMemoryFlags>(0), data, mapped, 0, size,
                                     new Mapping{data, mapped, 0}, give_back);
}

void release_buffers() {
  std::lock_guard<std::mutex> hold(cache_lock);
  expire(G_MAXINT64);
}

}  // namespace lfgst
