#include "lf/io/still_cache.h"

#include <fcntl.h>
#include <libdeflate.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <system_error>
#include <thread>
#include <vector>

namespace fs = std::filesystem;

namespace lf {
namespace {

constexpr char kMagic[8] = {'L', 'F', 'S', 'T', 'I', 'L', 'L', '1'};

// What the cache file's header holds, in this order (host byte order: the
// cache never leaves the machine).
struct Header {
  char magic[8];
  std::uint32_t width, height, type, path_bytes;
  std::uint64_t source_size, source_inode;
  std::int64_t source_mtime_ns;
  std::uint32_t pixels_crc32, reserved;
};
static_assert(sizeof(Header) == 56, "no padding in the header");

struct Source {
  std::string path;  // absolute
  std::uint64_t size = 0, inode = 0;
  std::int64_t mtime_ns = 0;
};

bool stat_source(const std::string& image, Source* s) {
  struct stat st;
  if (::stat(image.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  std::error_code ec;
  const fs::path abs = fs::absolute(image, ec);
  if (ec) return false;
  s->path = abs.lexically_normal().string();
  s->size = static_cast<std::uint64_t>(st.st_size);
  s->inode = static_cast<std::uint64_t>(st.st_ino);
  s->mtime_ns = static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000000000 + st.st_mtim.tv_nsec;
  return true;
}

// FNV-1a, 64 bits: the file name. Collisions are harmless: the header names
// the source in full.
std::uint64_t fnv1a(const void* data, size_t n, std::uint64_t h = 0xcbf29ce484222325ull) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  return h;
}

Header header_for(const Source& s, int width, int height, int type) {
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.width = static_cast<std::uint32_t>(width);
  h.height = static_cast<std::uint32_t>(height);
  h.type = static_cast<std::uint32_t>(type);
  h.path_bytes = static_cast<std::uint32_t>(s.path.size());
  h.source_size = s.size;
  h.source_inode = s.inode;
  h.source_mtime_ns = s.mtime_ns;
  return h;
}

std::string key_name(const Header& h, const std::string& path) {
  Header k = h;
  k.pixels_crc32 = 0;
  std::uint64_t v = fnv1a(&k, sizeof k);
  v = fnv1a(path.data(), path.size(), v);
  char name[32];
  std::snprintf(name, sizeof name, "%016llx", static_cast<unsigned long long>(v));
  return name;
}

// All n bytes through `io` (::read or ::write), retrying short transfers
// and EINTR; false on an error or end of file.
template <typename Byte, typename Io>
bool transfer_all(int fd, Byte* p, size_t n, Io io) {
  while (n > 0) {
    const ssize_t r = io(fd, p, n);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) return false;
    p += r;
    n -= static_cast<size_t>(r);
  }
  return true;
}
bool read_all(int fd, void* data, size_t n) {
  return transfer_all(fd, static_cast<char*>(data), n, ::read);
}
bool write_all(int fd, const void* data, size_t n) {
  return transfer_all(fd, static_cast<const char*>(data), n, ::write);
}

std::uint32_t crc_of(const cv::Mat& m) {
  return libdeflate_crc32(0, m.data, m.total() * m.elemSize());
}

// The cached pixels, or an empty matrix.
cv::Mat load(const std::string& file, const Header& want, const std::string& path) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return {};
  cv::Mat m;
  struct stat st;
  const size_t pixels = size_t(want.width) * want.height * CV_ELEM_SIZE(int(want.type));
  Header got;
  std::string got_path(path.size(), '\0');
  if (::fstat(fd, &st) == 0 &&
      static_cast<size_t>(st.st_size) == sizeof got + path.size() + pixels &&
      read_all(fd, &got, sizeof got) && read_all(fd, got_path.data(), got_path.size()) &&
      got_path == path) {
    Header cmp = got;
    cmp.pixels_crc32 = 0;
    if (std::memcmp(&cmp, &want, sizeof want) == 0) {
      m.create(int(want.height), int(want.width), int(want.type));
      if (!read_all(fd, m.data, pixels) || crc_of(m) != got.pixels_crc32) m.release();
    }
  }
  if (!m.empty()) ::futimens(fd, nullptr);  // recently used
  ::close(fd);
  return m;
}

// Removes the least recently used *.still files until the rest total at most
// max_bytes (`keep` stays), and temporary files over a minute old (a writer
// that was killed).
void evict(const fs::path& dir, std::uintmax_t max_bytes, const fs::path& keep) {
  struct Entry {
    fs::file_time_type t;
    std::uintmax_t bytes;
    fs::path p;
  };
  std::vector<Entry> files;
  std::uintmax_t total = 0;
  std::error_code ec;
  const auto now = fs::file_time_type::clock::now();
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& p = it->path();
    std::error_code e2;
    const auto t = fs::last_write_time(p, e2);
    if (e2) continue;
    if (p.extension() == ".tmp") {
      if (now - t > std::chrono::minutes(1)) fs::remove(p, e2);
      continue;
    }
    if (p.extension() != ".still") continue;
    const std::uintmax_t b = fs::file_size(p, e2);
    if (e2) continue;
    total += b;
    if (p != keep) files.push_back({t, b, p});
  }
  std::sort(files.begin(), files.end(), [](const Entry& a, const Entry& b) { return a.t < b.t; });
  for (const Entry& f : files) {
    if (total <= max_bytes) break;
    std::error_code e2;
    if (fs::remove(f.p, e2)) total -= f.bytes;
  }
}

// Writes `m` as `file` (through a temporary file and a rename). Returns ""
// or what went wrong.
std::string store(const fs::path& dir, const std::string& file, Header h, const std::string& path,
                  const cv::Mat& m, std::uintmax_t max_bytes) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return "cannot create " + dir.string() + ": " + ec.message();
  std::string tmp = file + ".XXXXXX.tmp";
  const int fd = ::mkstemps(tmp.data(), 4);
  if (fd < 0) return "cannot write in " + dir.string() + ": " + std::strerror(errno);
  h.pixels_crc32 = crc_of(m);
  const bool ok = write_all(fd, &h, sizeof h) && write_all(fd, path.data(), path.size()) &&
                  write_all(fd, m.data, m.total() * m.elemSize());
  const int err = errno;
  if (::close(fd) != 0 || !ok || ::rename(tmp.c_str(), file.c_str()) != 0) {
    const std::string why = ok ? std::strerror(errno) : std::strerror(err);
    ::unlink(tmp.c_str());
    return "cannot write " + file + ": " + why;
  }
  evict(dir, max_bytes, file);
  return "";
}

}  // namespace

cv::Mat cached_still(const StillCache& cache, const std::string& image, int width, int height,
                     int type, const std::function<cv::Mat()>& decode, StillSource* source,
                     std::string* note) {
  if (note) note->clear();
  if (source) *source = StillSource::kDecoded;
  auto decoded = [&] {
    cv::Mat m = decode();
    if (m.cols != width || m.rows != height || m.type() != type)
      throw std::logic_error("cached_still: decode() gave " + std::to_string(m.cols) + "x" +
                             std::to_string(m.rows) + " of type " + std::to_string(m.type()) +
                             ", not " + std::to_string(width) + "x" + std::to_string(height) +
                             " of type " + std::to_string(type));
    return m.isContinuous() ? m : m.clone();
  };
  Source s;
  if (cache.dir.empty() || width <= 0 || height <= 0 || !stat_source(image, &s)) return decoded();
  const Header h = header_for(s, width, height, type);
  const fs::path dir(cache.dir);
  const std::string file = (dir / (key_name(h, s.path) + ".still")).string();
  if (cv::Mat m = load(file, h, s.path); !m.empty()) {
    if (source) *source = StillSource::kCache;
    return m;
  }
  cv::Mat m = decoded();
  std::string why = store(dir, file, h, s.path, m, cache.max_bytes);
  if (note) *note = std::move(why);
  return m;
}

namespace {
std::mutex slot_mutex;
std::condition_variable slot_free;
unsigned slots_busy = 0;
}  // namespace

DecodeSlot::DecodeSlot() {
  std::unique_lock<std::mutex> l(slot_mutex);
  slot_free.wait(l, [] { return slots_busy < std::max(1u, std::thread::hardware_concurrency()); });
  ++slots_busy;
}

DecodeSlot::~DecodeSlot() {
  {
    std::lock_guard<std::mutex> l(slot_mutex);
    --slots_busy;
  }
  slot_free.notify_one();
}

}  // namespace lf
