// Decoded camera stills kept on disk (a cache), so that a process that
// starts again reads its cameras' images in milliseconds instead of decoding
// them again. A camera host replaying a dataset (lfcamsrc mode=dataset)
// decodes one 1400x800 Chess PNG in about 50 ms on one core; a restarted host
// of 16 such cameras spent 0.4-1.1 s decoding before it could contribute
// complete frames again (issue 15's rejoin within 1 s), while reading 16
// cached images takes a few ms.
//
// One file per image, size and pixel type:
//   DIR/<64-bit key, 16 hex digits>.still
// with a header that names its source (absolute path, size in bytes,
// modification time in ns, inode) and the pixels' width, height and OpenCV
// type, then the pixels row by row, no padding. A source file that changes
// (size, time or inode) misses; a cache file whose header disagrees, or
// whose length is not exactly header + pixels, misses and is replaced. The
// size read is the one asked for, never one taken from the file.
//
// Files are written to a temporary name in DIR and renamed into place, so
// processes that share DIR (the camera hosts of one machine) never read a
// half-written file. After a write, the least recently used files
// (modification time, refreshed on every hit) are removed until DIR's
// *.still files total at most `max_bytes`.
//
// Errors of the cache itself (DIR not writable, disk full, a damaged file)
// never fail a read: the image is decoded as without a cache, and `note`
// says what went wrong.
#pragma once

#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <string>

namespace lf {

struct StillCache {
  std::string dir;                                     // empty: no cache (decode every time)
  std::uintmax_t max_bytes = std::uintmax_t(1) << 30;  // 1 GiB
};

enum class StillSource { kDecoded, kCache };

// The still of `image` as `decode()` makes it: a continuous `width` x
// `height` matrix of `type` (e.g. CV_8UC4). From `cache` when it holds this
// image at this size and type, else from decode(), which is then stored.
// decode()'s exceptions propagate (a missing or undecodable image); a
// decode() result of another size or type throws std::logic_error.
// `source` (optional) says where the pixels came from; `note` (optional)
// gets a line about a cache error ("" if none).
cv::Mat cached_still(const StillCache& cache, const std::string& image, int width, int height,
                     int type, const std::function<cv::Mat()>& decode,
                     StillSource* source = nullptr, std::string* note = nullptr);

// One of as many decodes of stills at once as the machine has cores,
// process-wide, held while it lives (a process of 64 cameras would
// otherwise hold 64 full-size images being decoded at once).
class DecodeSlot {
 public:
  DecodeSlot();
  ~DecodeSlot();
  DecodeSlot(const DecodeSlot&) = delete;
  DecodeSlot& operator=(const DecodeSlot&) = delete;
};

}  // namespace lf
