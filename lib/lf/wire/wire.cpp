#include "lf/wire/wire.h"

#include <libdeflate.h>
#include <turbojpeg.h>

#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <string>

#include "lf/geometry/rotation.h"
#include "lf/wire/byte_io.h"
#include "lf/wire/jpeg_segments.h"

namespace lf {

using wire_io::crc;
using wire_io::Reader;
using wire_io::tables_of;
using wire_io::walk_segments;
using wire_io::Writer;

namespace {

struct TjDeleter {
  void operator()(void* h) const {
    if (h) tjDestroy(h);
  }
};
using TjHandle = std::unique_ptr<void, TjDeleter>;

tjhandle compressor() {
  thread_local TjHandle h(tjInitCompress());
  if (!h) throw std::runtime_error("TurboJPEG: cannot create a compressor");
  return h.get();
}
// This thread's decompressor. After TurboJPEG refuses a stream (an error
// in its header or data), the handle is made anew: libjpeg's marker reader
// keeps the refused stream's state, and every later stream read with that
// handle failed ("Bogus marker length"), so one bad fragment from a peer
// stopped every good one decoded on that thread after it.
TjHandle& decompressor_handle() {
  thread_local TjHandle h;
  if (!h) h.reset(tjInitDecompress());
  if (!h) throw std::runtime_error("TurboJPEG: cannot create a decompressor");
  return h;
}
tjhandle decompressor() {
  return decompressor_handle().get();
}

[[noreturn]] void bad_fragment(const std::string& what) {
  throw WireError("fragment: " + what);
}

// JPEG payload (encoding 2): the colour as a 3-component 4:2:0 JPEG and the
// blending weight as a greyscale JPEG. The weight is a piecewise-linear ramp
// (1 at the camera, 0 at its neighbours); where it has no steps (the
// fragment lies inside the camera's image: adjacent weights differ by at
// most kMaxHalfStep) it goes at half resolution, 2x2 means, restored by
// bilinear upsampling (exact where the ramp is linear, within a level or two
// at its creases), at a quarter of the blocks. Its JPEG cost grows as
// fragments shrink and ramps steepen; at half resolution that growth no
// longer makes the bytes per output frame grow with the number of cameras.
// Both streams leave out their DQT and DHT segments when they are libjpeg's
// standard tables for the quality (ITU T.81 Annex K, scaled as
// jpeg_set_quality), which the receiver puts back, as RTP/JPEG (RFC 2435)
// does: about 570 bytes per fragment otherwise.
constexpr uint8_t kTablesOmitted = 1, kHalfResolutionWeight = 2;
constexpr int kMaxHalfStep = 16;

// The largest |a[c + 1] - a[c]| for c in [b, e - 1), and the largest
// |a[c] - n[c]| for c in [lo, hi): branch-free, so the compiler vectorises.
inline int max_step_along(const uint8_t* a, int b, int e) {
  int m = 0;
  for (int c = b; c + 1 < e; ++c) m = std::max(m, std::abs(a[c + 1] - a[c]));
  return m;
}
inline int max_step_across(const uint8_t* a, const uint8_t* n, int lo, int hi) {
  int m = 0;
  for (int c = lo; c < hi; ++c) m = std::max(m, std::abs(n[c] - a[c]));
  return m;
}

// True if no two adjacent span pixels' weights differ by more than kMaxHalfStep.
bool weight_is_smooth(const cv::Mat& alpha, const std::vector<std::array<uint16_t, 2>>& spans,
                      int x0) {
  for (int r = 0; r < alpha.rows; ++r) {
    const int b = spans[r][0] - x0, e = spans[r][1] - x0;
    const uint8_t* a = alpha.ptr<uint8_t>(r);
    if (max_step_along(a, b, e) > kMaxHalfStep) return false;
    if (r + 1 < alpha.rows) {
      const int lo = std::max(b, spans[r + 1][0] - x0), hi = std::min(e, spans[r + 1][1] - x0);
      if (max_step_across(a, alpha.ptr<uint8_t>(r + 1), lo, hi) > kMaxHalfStep) return false;
    }
  }
  return true;
}

enum class JpegKind { kColour, kGrey };

// A TurboJPEG output buffer, kept from call to call (TJFLAG_NOREALLOC).
struct TjBuffer {
  unsigned char* p = nullptr;
  unsigned long capacity = 0;
  TjBuffer() = default;
  TjBuffer(const TjBuffer&) = delete;
  TjBuffer& operator=(const TjBuffer&) = delete;
  ~TjBuffer() { tjFree(p); }
};

// Compresses `pixels` (RGBX for kColour, 8-bit grey for kGrey) with
// TurboJPEG, 4:2:0 for colour, into `out`; returns the stream's size.
size_t compress_into(TjBuffer& out, const uint8_t* pixels, int w, int h, JpegKind kind,
                     int quality) {
  const bool colour = kind == JpegKind::kColour;
  const int samp = colour ? TJSAMP_420 : TJSAMP_GRAY;
  const unsigned long bound = tjBufSize(w, h, samp);
  if (bound == static_cast<unsigned long>(-1))
    throw std::runtime_error("fragment JPEG compression failed: " +
                             std::string(tjGetErrorStr2(compressor())));
  if (bound > out.capacity) {
    tjFree(out.p);
    out.p = tjAlloc(static_cast<int>(bound));
    out.capacity = out.p ? bound : 0;
    if (!out.p) throw std::bad_alloc();
  }
  unsigned char* jpeg = out.p;
  unsigned long jsize = out.capacity;
  if (tjCompress2(compressor(), pixels, w, w * (colour ? 4 : 1), h, colour ? TJPF_RGBX : TJPF_GRAY,
                  &jpeg, &jsize, samp, quality, TJFLAG_NOREALLOC) != 0)
    throw std::runtime_error("fragment JPEG compression failed: " +
                             std::string(tjGetErrorStr2(compressor())));
  return jsize;
}

// The DQT + DHT segments TurboJPEG writes at `quality`, from a tiny
// reference image; cached.
const std::vector<uint8_t>& standard_tables(JpegKind kind, int quality) {
  static std::mutex m;
  static std::map<std::pair<int, int>, std::vector<uint8_t>> cache;
  std::lock_guard<std::mutex> lock(m);
  const std::pair<int, int> key(static_cast<int>(kind), quality);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  const std::vector<uint8_t> img(16 * 16 * 4, 128);
  TjBuffer j;
  const size_t n = compress_into(j, img.data(), 16, 16, kind, quality);
  std::vector<uint8_t> tables;
  if (!tables_of(j.p, n, tables) || tables.empty())
    throw std::runtime_error("TurboJPEG: unexpected reference stream");
  return cache[key] = tables;
}

// Puts the standard tables back after SOI, into `out`.
void complete(const uint8_t* j, size_t n, JpegKind kind, int quality, std::vector<uint8_t>& out) {
  if (n < 2 || j[0] != 0xFF || j[1] != 0xD8) bad_fragment("JPEG has no SOI marker");
  const std::vector<uint8_t>& t = standard_tables(kind, quality);
  out.clear();
  out.reserve(n + t.size());
  out.insert(out.end(), j, j + 2);
  out.insert(out.end(), t.begin(), t.end());
  out.insert(out.end(), j + 2, j + n);
}

// A buffer kept from call to call that only grows: no allocation, zero fill
// or page faults once it has the size of the largest fragment.
struct Scratch {
  std::vector<uint8_t> v;
  uint8_t* get(size_t n) {
    if (v.size() < n) v.resize(n);
    return v.data();
  }
};

// Fills the pixels outside the spans (ignored by the receiver) by repeating
// the nearest span pixel along the row, and empty rows from the nearest
// non-empty row, so the JPEG spends no bits on edges between the fragment
// and a black surround.
void pad_outside_spans(uint8_t* rgba, int w, int h,
                       const std::vector<std::array<uint16_t, 2>>& spans, int x0) {
  auto px = [&](int r, int c) { return rgba + (static_cast<size_t>(r) * w + c) * 4; };
  int last_full = -1;
  for (int r = 0; r < h; ++r) {
    const int b = spans[r][0] - x0, e = spans[r][1] - x0;
    if (e <= b) continue;
    for (int c = 0; c < b; ++c) std::memcpy(px(r, c), px(r, b), 4);
    for (int c = e; c < w; ++c) std::memcpy(px(r, c), px(r, e - 1), 4);
    // Rows without pixels since the last row with some: the nearer one.
    for (int q = last_full + 1; q < r; ++q)
      std::memcpy(px(q, 0), px(last_full >= 0 && q - last_full <= r - q ? last_full : r, 0),
                  static_cast<size_t>(w) * 4);
    last_full = r;
  }
  if (last_full >= 0)
    for (int q = last_full + 1; q < h; ++q)
      std::memcpy(px(q, 0), px(last_full, 0), static_cast<size_t>(w) * 4);
}

// Decompresses a w x h JPEG of the given kind into `out` (RGBX or grey,
// w * h * 4 or w * h bytes).
void decompress(const uint8_t* j, size_t n, int w, int h, JpegKind kind, uint8_t* out,
                const char* what) {
  int jw = 0, jh = 0, sub = 0, cs = 0;
  // The error's text, then a fresh handle for the next stream.
  auto refuse = [&](const char* part) {
    const std::string why =
        std::string(what) + " JPEG " + part + ": " + tjGetErrorStr2(decompressor());
    decompressor_handle().reset();
    bad_fragment(why);
  };
  if (tjDecompressHeader3(decompressor(), j, static_cast<unsigned long>(n), &jw, &jh, &sub, &cs) !=
      0)
    refuse("header");
  if (jw != w || jh != h)
    bad_fragment(std::string(what) + " JPEG is " + std::to_string(jw) + "x" + std::to_string(jh) +
                 ", expected " + std::to_string(w) + "x" + std::to_string(h));
  const bool colour = kind == JpegKind::kColour;
  if (colour ? cs != TJCS_YCbCr : cs != TJCS_GRAY)
    bad_fragment(std::string(what) + " JPEG has the wrong colour space");
  if (tjDecompress2(decompressor(), j, static_cast<unsigned long>(n), out, w, w * (colour ? 4 : 1),
                    h, colour ? TJPF_RGBX : TJPF_GRAY,
                    TJFLAG_STOPONWARNING | TJFLAG_LIMITSCANS) != 0)
    refuse("data");
}

}  // namespace

namespace {
// The fragment header up to (not including) its CRC, bytes 0..51.
bool is_sum(const Fragment& f) {
  return f.cameras != 1 || f.weight_shift != 0;
}
size_t header_size(const Fragment& f) {
  return is_sum(f) ? kSumFragmentHeaderSize : kFragmentHeaderSize;
}

// The header up to (not including) its CRC: bytes 0..51, or 0..55 for a
// partial sum (version 2).
// Version 2's flags (byte 55).
constexpr uint8_t kSpansDeflated = 1;

void write_header(const Fragment& f, Encoding enc, int quality, size_t payload_size,
                  std::vector<uint8_t>& out, bool deflated_spans = false) {
  Writer w(out);
  w.bytes("LFFR", 4);
  w.u16(is_sum(f) ? 2 : 1);
  w.u16(static_cast<uint16_t>(header_size(f)));
  w.u32(f.viewer_id);
  w.u64(f.sequence);
  w.u32(f.camera_id);
  w.u64(static_cast<uint64_t>(f.capture_time_ns));
  w.u16(static_cast<uint16_t>(f.out_width));
  w.u16(static_cast<uint16_t>(f.out_height));
  const bool e = enc == Encoding::kEmpty;
  w.u16(e ? 0 : f.rect.x), w.u16(e ? 0 : f.rect.y);
  w.u16(e ? 0 : f.rect.width), w.u16(e ? 0 : f.rect.height);
  w.u8(static_cast<uint8_t>(enc));
  w.u8(enc == Encoding::kJpeg ? static_cast<uint8_t>(quality) : 0);
  w.u8(f.layer);
  w.u8(0);
  w.u32(static_cast<uint32_t>(payload_size));
  if (is_sum(f)) {
    w.u16(f.cameras);
    w.u8(f.weight_shift);
    w.u8(deflated_spans ? kSpansDeflated : 0);
  }
}

// The row spans of a non-empty fragment, relative to its rect.x.
void write_spans(const Fragment& f, Writer& w) {
  for (const auto& s : f.spans) {
    w.u16(static_cast<uint16_t>(s[0] - f.rect.x));
    w.u16(static_cast<uint16_t>(s[1] - f.rect.x));
  }
}

// A partial sum's spans (version 2, flag kSpansDeflated): each row's begin
// and end minus the row before's (mod 2^16; the first row's minus 0),
// big-endian u16 pairs, as one raw DEFLATE stream (RFC 1951, libdeflate)
// after its size (u32). A sum's edges are nearly straight, so its spans
// shrink from 4 bytes a row to a few bytes in all.
void write_deflated_spans(const Fragment& f, Writer& w) {
  std::vector<uint8_t> deltas;
  Writer d(deltas);
  int b0 = 0, e0 = 0;
  for (const auto& s : f.spans) {
    const int b = s[0] - f.rect.x, e = s[1] - f.rect.x;
    d.u16(static_cast<uint16_t>(b - b0)), d.u16(static_cast<uint16_t>(e - e0));
    b0 = b, e0 = e;
  }
  struct Deleter {
    void operator()(libdeflate_compressor* c) const { libdeflate_free_compressor(c); }
  };
  thread_local std::unique_ptr<libdeflate_compressor, Deleter> c(libdeflate_alloc_compressor(9));
  if (!c) throw std::runtime_error("libdeflate: cannot make a compressor");
  std::vector<uint8_t> out(libdeflate_deflate_compress_bound(c.get(), deltas.size()));
  const size_t n =
      libdeflate_deflate_compress(c.get(), deltas.data(), deltas.size(), out.data(), out.size());
  if (n == 0) throw std::runtime_error("libdeflate: the spans do not compress");
  w.u32(static_cast<uint32_t>(n));
  w.bytes(out.data(), n);
}
}  // namespace

namespace {
// This thread's JPEG buffers, kept from fragment to fragment.
struct JpegBuffers {
  Scratch rgba, alpha, half;
  TjBuffer colour, weight;
  std::vector<uint8_t> ctables, wtables;
};
thread_local JpegBuffers jpeg_buffers;

// The JPEG payload after the spans, from `full`: the rect's w x h RGBA
// image with the span pixels in place (the rest is overwritten: the
// padding).
void write_jpeg(const Fragment& f, uint8_t* full, int quality, Writer& p) {
  JpegBuffers& b = jpeg_buffers;
  const int w = f.rect.width, h = f.rect.height;
  pad_outside_spans(full, w, h, f.spans, f.rect.x);
  const size_t csize = compress_into(b.colour, full, w, h, JpegKind::kColour, quality);
  cv::Mat alpha(h, w, CV_8U, b.alpha.get(static_cast<size_t>(w) * h));
  cv::extractChannel(cv::Mat(h, w, CV_8UC4, full), alpha, 3);  // into alpha's memory
  // Spans-only check: the padding outside them repeats edge values.
  const bool half = weight_is_smooth(alpha, f.spans, f.rect.x);
  cv::Mat weight_img = alpha;
  if (half) {
    const int hw = (w + 1) / 2, hh = (h + 1) / 2;
    weight_img = cv::Mat(hh, hw, CV_8U, b.half.get(static_cast<size_t>(hw) * hh));
    cv::resize(alpha, weight_img, cv::Size(hw, hh), 0, 0, cv::INTER_AREA);
  }
  const size_t wsize = compress_into(b.weight, weight_img.data, weight_img.cols, weight_img.rows,
                                     JpegKind::kGrey, quality);
  // The tables are left out when both streams have the standard ones.
  const bool omit = tables_of(b.colour.p, csize, b.ctables) &&
                    b.ctables == standard_tables(JpegKind::kColour, quality) &&
                    tables_of(b.weight.p, wsize, b.wtables) &&
                    b.wtables == standard_tables(JpegKind::kGrey, quality);
  p.u8(static_cast<uint8_t>((omit ? kTablesOmitted : 0) | (half ? kHalfResolutionWeight : 0)));
  p.u32(static_cast<uint32_t>(omit ? csize - b.ctables.size() : csize));
  auto put = [&](const uint8_t* j, size_t n) {
    if (!omit) return p.bytes(j, n);
    walk_segments(j, n, [&](bool table, const uint8_t* q, size_t k) {
      if (!table) p.bytes(q, k);
    });
  };
  put(b.colour.p, csize);
  put(b.weight.p, wsize);
}

// The header and CRC before the payload.
std::vector<uint8_t> finish_fragment(const Fragment& f, Encoding enc, int quality,
                                     const std::vector<uint8_t>& payload, bool deflated) {
  if (payload.size() > kMaxPayload)
    throw std::invalid_argument("serialize_fragment: payload exceeds 64 MiB");
  std::vector<uint8_t> out;
  out.reserve(header_size(f) + payload.size());
  write_header(f, enc, quality, payload.size(), out, deflated);
  const uint32_t sum = crc(out.data(), out.size(), payload.data(), payload.size());
  Writer(out).u32(sum);
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}
}  // namespace

std::vector<uint8_t> serialize_fragment(const Fragment& f, Encoding enc, int quality) {
  check_fragment(f);
  if (quality < 1 || quality > 100)
    throw std::invalid_argument("serialize_fragment: JPEG quality must be 1..100");
  if (f.empty()) enc = Encoding::kEmpty;
  if (enc != Encoding::kEmpty && enc != Encoding::kRaw && enc != Encoding::kJpeg)
    throw std::invalid_argument("serialize_fragment: unknown encoding");
  std::vector<uint8_t> payload;
  const bool deflated = is_sum(f) && enc != Encoding::kEmpty;
  if (enc != Encoding::kEmpty) {
    Writer p(payload);
    if (deflated)
      write_deflated_spans(f, p);
    else
      write_spans(f, p);
    if (enc == Encoding::kRaw) {
      p.bytes(f.pixels.data(), f.pixels.size());
    } else {
      // Every pixel of the rectangle is written: the spans' from the
      // fragment here, the others by write_jpeg's padding.
      const int w = f.rect.width, h = f.rect.height;
      uint8_t* full = jpeg_buffers.rgba.get(static_cast<size_t>(w) * h * 4);
      const uint8_t* src = f.pixels.data();
      for (int r = 0; r < h; ++r) {
        const int n = 4 * (f.spans[r][1] - f.spans[r][0]);
        std::memcpy(full + (static_cast<size_t>(r) * w + f.spans[r][0] - f.rect.x) * 4, src, n);
        src += n;
      }
      write_jpeg(f, full, quality, p);
    }
  }
  return finish_fragment(f, enc, quality, payload, deflated);
}

std::vector<uint8_t> serialize_jpeg_fragment(const Fragment& f, uint8_t* rect_rgba, int quality) {
  if (!f.pixels.empty())
    throw std::invalid_argument("serialize_jpeg_fragment: the pixels are in the rectangle");
  check_fragment_geometry(f);
  if (quality < 1 || quality > 100)
    throw std::invalid_argument("serialize_jpeg_fragment: JPEG quality must be 1..100");
  if (f.empty()) return finish_fragment(f, Encoding::kEmpty, quality, {}, false);
  std::vector<uint8_t> payload;
  const bool deflated = is_sum(f);
  Writer p(payload);
  if (deflated)
    write_deflated_spans(f, p);
  else
    write_spans(f, p);
  write_jpeg(f, rect_rgba, quality, p);
  return finish_fragment(f, Encoding::kJpeg, quality, payload, deflated);
}

size_t raw_fragment_size(const Fragment& f) {
  const size_t n = check_fragment_geometry(f);
  if (f.empty()) return header_size(f);
  const size_t payload = 4 * f.spans.size() + 4 * n;
  if (payload > kMaxPayload)
    throw std::invalid_argument("raw_fragment_size: payload exceeds 64 MiB");
  return header_size(f) + payload;
}

uint8_t* write_raw_fragment(const Fragment& f, uint8_t* out, size_t size) {
  const size_t need = raw_fragment_size(f);
  if (size != need)
    throw std::invalid_argument("write_raw_fragment: buffer is " + std::to_string(size) +
                                " bytes, the fragment takes " + std::to_string(need));
  std::vector<uint8_t> head;
  head.reserve(header_size(f) + 4 * f.spans.size());
  const Encoding enc = f.empty() ? Encoding::kEmpty : Encoding::kRaw;
  write_header(f, enc, 0, size - header_size(f), head);
  Writer w(head);
  w.u32(0);  // the CRC: seal_fragment()
  write_spans(f, w);
  std::memcpy(out, head.data(), head.size());
  return out + head.size();
}

void seal_fragment(uint8_t* out, size_t size) {
  const size_t hs = peek_fragment_header(out, size).header_size;
  const uint32_t sum = crc(out, hs - 4, out + hs, size - hs);
  for (int i = 0; i < 4; ++i) out[hs - 4 + i] = static_cast<uint8_t>(sum >> (24 - 8 * i));
}

FragmentHeader peek_fragment_header(const uint8_t* data, size_t size) {
  if (data == nullptr && size > 0) bad_fragment("null buffer");
  if (size < kFragmentHeaderSize)
    bad_fragment("truncated header (" + std::to_string(size) + " of " +
                 std::to_string(kFragmentHeaderSize) + " bytes)");
  Reader r(data, size, "fragment");
  if (std::memcmp(data, "LFFR", 4) != 0) bad_fragment("bad magic (not an lf fragment)");
  for (int i = 0; i < 4; ++i) r.u8();
  const uint16_t version = r.u16();
  if (version != 1 && version != 2) bad_fragment("unsupported version " + std::to_string(version));
  const uint16_t hsize = r.u16();
  if (hsize != (version == 1 ? kFragmentHeaderSize : kSumFragmentHeaderSize))
    bad_fragment("bad header size " + std::to_string(hsize) + " for version " +
                 std::to_string(version));
  if (size < hsize)
    bad_fragment("truncated header (" + std::to_string(size) + " of " + std::to_string(hsize) +
                 " bytes)");
  FragmentHeader h;
  h.header_size = hsize;
  if (version == 2) {
    h.cameras = static_cast<uint16_t>((data[52] << 8) | data[53]);
    h.weight_shift = data[54];
    if (h.cameras < 1 || h.cameras > kMaxSummedCameras)
      bad_fragment("a sum of " + std::to_string(h.cameras) + " cameras (1.." +
                   std::to_string(kMaxSummedCameras) + ")");
    if (h.weight_shift > kMaxWeightShift)
      bad_fragment("weight shift " + std::to_string(h.weight_shift) + " over " +
                   std::to_string(kMaxWeightShift));
    h.deflated_spans = data[55] & kSpansDeflated;
    if (data[55] & ~kSpansDeflated) bad_fragment("unknown flags " + std::to_string(data[55]));
  }
  h.viewer_id = r.u32();
  h.sequence = r.u64();
  h.camera_id = r.u32();
  h.capture_time_ns = static_cast<int64_t>(r.u64());
  h.encoding = static_cast<Encoding>(data[44]);
  h.layer = data[46];
  h.payload_size = (uint32_t{data[48]} << 24) | (uint32_t{data[49]} << 16) |
                   (uint32_t{data[50]} << 8) | uint32_t{data[51]};
  return h;
}

namespace {
// raw_pixels: null, or where a raw payload's pixels are pointed to instead
// of being copied (other encodings: at the decoded f.pixels). raw_out: null,
// or (JPEG payloads only) where the decoded fragment goes in the raw wire
// format, sealed, instead of into f.pixels (decode_jpeg_to_raw).
Fragment parse_fragment_impl(const uint8_t* data, size_t size, Encoding* enc_out, size_t max_pixels,
                             const uint8_t** raw_pixels, bool check_crc,
                             const std::function<uint8_t*(size_t)>* raw_out = nullptr) {
  const FragmentHeader head = peek_fragment_header(data, size);
  Reader r(data + 32, size - 32, "fragment");
  Fragment f;
  f.viewer_id = head.viewer_id;
  f.sequence = head.sequence;
  f.camera_id = head.camera_id;
  f.capture_time_ns = head.capture_time_ns;
  f.cameras = head.cameras;
  f.weight_shift = head.weight_shift;
  const size_t hs = head.header_size;
  f.out_width = r.u16();
  f.out_height = r.u16();
  const int x = r.u16(), y = r.u16(), w = r.u16(), h = r.u16();
  const uint8_t enc = r.u8();
  const uint8_t quality = r.u8();
  f.layer = r.u8();
  const uint8_t reserved = r.u8();
  const uint32_t psize = r.u32();
  const uint32_t sum = Reader(data + hs - 4, 4, "fragment").u32();
  if (f.layer > 1) bad_fragment("layer " + std::to_string(f.layer) + " is not 0 or 1");
  if (reserved != 0) bad_fragment("reserved field is not zero");
  if (f.out_width < 1 || f.out_height < 1 || f.out_width > 16384 || f.out_height > 16384)
    bad_fragment("output size " + std::to_string(f.out_width) + "x" + std::to_string(f.out_height) +
                 " out of range 1..16384");
  if (psize > kMaxPayload)
    bad_fragment("payload size " + std::to_string(psize) + " exceeds 64 MiB");
  if (size != hs + psize)
    bad_fragment("buffer is " + std::to_string(size) + " bytes, header announces " +
                 std::to_string(hs + psize) +
                 (size < hs + psize ? " (truncated)" : " (trailing bytes)"));
  const uint8_t* payload = data + hs;
  if (check_crc && crc(data, hs - 4, payload, psize) != sum)
    bad_fragment("CRC mismatch (corrupt data)");
  if (enc > 2) bad_fragment("unknown encoding " + std::to_string(enc));
  if (enc == 2 && (quality < 1 || quality > 100))
    bad_fragment("JPEG quality " + std::to_string(quality) + " out of range 1..100");
  if (enc_out) *enc_out = static_cast<Encoding>(enc);
  if (raw_pixels) *raw_pixels = nullptr;
  if (enc == 0) {
    if (x || y || w || h || psize) bad_fragment("empty fragment with a rectangle or payload");
    return f;
  }
  if (w == 0 || h == 0) bad_fragment("non-empty fragment with an empty rectangle");
  if (x + w > f.out_width || y + h > f.out_height)
    bad_fragment("rectangle " + std::to_string(w) + "x" + std::to_string(h) + "+" +
                 std::to_string(x) + "+" + std::to_string(y) + " exceeds the output frame");
  if (static_cast<size_t>(w) * h > max_pixels)
    bad_fragment("rectangle of " + std::to_string(w) + "x" + std::to_string(h) +
                 " pixels exceeds the receiver's limit of " + std::to_string(max_pixels));
  f.rect = cv::Rect(x, y, w, h);
  Reader p(payload, psize, "fragment payload");
  size_t npix = 0;
  f.spans.resize(h);
  // Deflated spans (a partial sum) are inflated to exactly 4 bytes a row,
  // no more, then read as the plain ones, their deltas added up.
  std::vector<uint8_t> inflated;
  if (head.deflated_spans) {
    const uint32_t n = p.u32();
    if (n > psize - p.pos())
      bad_fragment("deflated spans of " + std::to_string(n) + " bytes exceed the payload");
    const uint8_t* packed = p.take(n);
    inflated.resize(4 * static_cast<size_t>(h));
    struct Deleter {
      void operator()(libdeflate_decompressor* d) const { libdeflate_free_decompressor(d); }
    };
    thread_local std::unique_ptr<libdeflate_decompressor, Deleter> d(
        libdeflate_alloc_decompressor());
    if (!d) throw std::runtime_error("libdeflate: cannot make a decompressor");
    size_t got = 0;
    if (libdeflate_deflate_decompress(d.get(), packed, n, inflated.data(), inflated.size(), &got) !=
            LIBDEFLATE_SUCCESS ||
        got != inflated.size())
      bad_fragment("deflated spans do not inflate to " + std::to_string(inflated.size()) +
                   " bytes");
  }
  Reader sp(head.deflated_spans ? inflated.data() : payload,
            head.deflated_spans ? inflated.size() : psize, "fragment spans");
  Reader& spans_in = head.deflated_spans ? sp : p;
  int b_prev = 0, e_prev = 0;
  for (int row = 0; row < h; ++row) {
    int b = spans_in.u16(), e = spans_in.u16();
    if (head.deflated_spans) {
      b = (b + b_prev) & 0xFFFF, e = (e + e_prev) & 0xFFFF;
      b_prev = b, e_prev = e;
    }
    if (b > e || e > w)
      bad_fragment("row " + std::to_string(row) + " span [" + std::to_string(b) + ", " +
                   std::to_string(e) + ") outside width " + std::to_string(w));
    f.spans[row] = {static_cast<uint16_t>(x + b), static_cast<uint16_t>(x + e)};
    npix += e - b;
  }
  const size_t rest = psize - p.pos();
  const uint8_t* body = payload + p.pos();
  if (enc == 1) {
    if (rest != 4 * npix)
      bad_fragment("raw payload has " + std::to_string(rest) + " pixel bytes, spans need " +
                   std::to_string(4 * npix));
    if (raw_pixels) {
      *raw_pixels = body;
      check_fragment_geometry(f);
      return f;
    }
    f.pixels.assign(body, body + rest);
  } else {
    const uint8_t flags = p.u8();
    const uint32_t csize = p.u32();
    if (flags & ~(kTablesOmitted | kHalfResolutionWeight))
      bad_fragment("unknown JPEG flags " + std::to_string(flags));
    const size_t left = psize - p.pos();
    if (csize > left)
      bad_fragment("colour JPEG of " + std::to_string(csize) + " bytes exceeds the payload");
    const uint8_t* cj = payload + p.pos();
    const uint8_t* wj = cj + csize;
    const size_t wsize = left - csize;
    // This thread's buffers, kept from fragment to fragment.
    struct Buffers {
      std::vector<uint8_t> c_whole, w_whole;
      Scratch colour, weight, alpha;
    };
    thread_local Buffers buf;
    size_t cn = csize, wn = wsize;
    if (flags & kTablesOmitted) {
      complete(cj, csize, JpegKind::kColour, quality, buf.c_whole);
      complete(wj, wsize, JpegKind::kGrey, quality, buf.w_whole);
      cj = buf.c_whole.data(), cn = buf.c_whole.size();
      wj = buf.w_whole.data(), wn = buf.w_whole.size();
    }
    uint8_t* colour = buf.colour.get(static_cast<size_t>(w) * h * 4);
    decompress(cj, cn, w, h, JpegKind::kColour, colour, "colour");
    const bool half = flags & kHalfResolutionWeight;
    const int hw = half ? (w + 1) / 2 : w, hh = half ? (h + 1) / 2 : h;
    cv::Mat alpha(hh, hw, CV_8U, buf.weight.get(static_cast<size_t>(hw) * hh));
    decompress(wj, wn, hw, hh, JpegKind::kGrey, alpha.data, "weight");
    if (half) {
      cv::Mat up(h, w, CV_8U, buf.alpha.get(static_cast<size_t>(w) * h));
      cv::resize(alpha, up, cv::Size(w, h), 0, 0, cv::INTER_LINEAR);  // into up's memory
      alpha = up;
    }
    // Into f.pixels, or straight into the raw wire format's pixels.
    uint8_t* raw = nullptr;
    size_t raw_size = 0;
    uint8_t* dst;
    if (raw_out) {
      raw_size = raw_fragment_size(f);
      raw = (*raw_out)(raw_size);
      dst = write_raw_fragment(f, raw, raw_size);
    } else {
      f.pixels.resize(4 * npix);
      dst = f.pixels.data();
    }
    // Colour and weight interleaved, a pixel as one 32-bit word (the bytes
    // R, G, B, weight in memory on either byte order), which compilers
    // vectorise as whole words (1.5-1.8x faster than byte by byte in a
    // micro-benchmark on this project's 2-core Intel VM).
    constexpr bool little = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;
    constexpr uint32_t kRgb = little ? 0x00FFFFFFu : 0xFFFFFF00u;
    constexpr int kWeightShift = little ? 24 : 0;
    for (int row = 0; row < h; ++row) {
      const int b = f.spans[row][0] - x, e = f.spans[row][1] - x;
      const uint8_t* src = colour + (static_cast<size_t>(row) * w + b) * 4;
      const uint8_t* a = alpha.ptr<uint8_t>(row) + b;
      for (int c = 0; c < e - b; ++c) {
        uint32_t px;
        std::memcpy(&px, src + 4 * c, 4);
        px = (px & kRgb) | (static_cast<uint32_t>(a[c]) << kWeightShift);
        std::memcpy(dst + 4 * c, &px, 4);
      }
      dst += 4 * static_cast<size_t>(e - b);
    }
    if (raw) {  // its geometry was checked by raw_fragment_size()
      seal_fragment(raw, raw_size);
      return f;
    }
  }
  check_fragment(f);
  if (raw_pixels) *raw_pixels = f.pixels.data();
  return f;
}
}  // namespace

Fragment parse_fragment(const uint8_t* data, size_t size, Encoding* enc_out, size_t max_pixels) {
  return parse_fragment_impl(data, size, enc_out, max_pixels, nullptr, true);
}

Fragment parse_fragment_in_place(const uint8_t* data, size_t size, const uint8_t** pixels,
                                 Encoding* enc_out, size_t max_pixels, bool check_crc) {
  if (!pixels) throw std::invalid_argument("parse_fragment_in_place: no pixel pointer");
  return parse_fragment_impl(data, size, enc_out, max_pixels, pixels, check_crc);
}

Fragment decode_jpeg_to_raw(const uint8_t* data, size_t size, size_t max_pixels,
                            const std::function<uint8_t*(size_t)>& out) {
  if (peek_fragment_header(data, size).encoding != Encoding::kJpeg)
    throw std::invalid_argument("decode_jpeg_to_raw: not a JPEG fragment");
  return parse_fragment_impl(data, size, nullptr, max_pixels, nullptr, true, &out);
}

}  // namespace lf
