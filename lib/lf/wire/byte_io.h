// Big-endian writing and bounds-checked reading of the wire formats
// (lib/lf/wire/wire.h): internal to lib/lf/wire, not installed.
#pragma once

#include <libdeflate.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "lf/wire/wire.h"

namespace lf::wire_io {

class Writer {
 public:
  explicit Writer(std::vector<uint8_t>& b) : b_(b) {}
  void u8(uint8_t v) { b_.push_back(v); }
  void u16(uint16_t v) { u8(v >> 8), u8(v & 0xff); }
  void u32(uint32_t v) { u16(v >> 16), u16(v & 0xffff); }
  void u64(uint64_t v) { u32(static_cast<uint32_t>(v >> 32)), u32(static_cast<uint32_t>(v)); }
  void f64(double d) {
    uint64_t v;
    std::memcpy(&v, &d, 8);
    u64(v);
  }
  void bytes(const void* p, size_t n) {
    const auto* c = static_cast<const uint8_t*>(p);
    b_.insert(b_.end(), c, c + n);
  }

 private:
  std::vector<uint8_t>& b_;
};

class Reader {
 public:
  Reader(const uint8_t* p, size_t n, const char* what) : p_(p), n_(n), what_(what) {}
  uint8_t u8() { return need(1), p_[pos_++]; }
  uint16_t u16() {
    const uint16_t hi = u8();
    return static_cast<uint16_t>(hi << 8 | u8());
  }
  uint32_t u32() {
    const uint32_t hi = u16();
    return hi << 16 | u16();
  }
  uint64_t u64() {
    const uint64_t hi = u32();
    return hi << 32 | u32();
  }
  double f64() {
    const uint64_t v = u64();
    double d;
    std::memcpy(&d, &v, 8);
    return d;
  }
  // The next k bytes, in place.
  const uint8_t* take(size_t k) {
    need(k);
    const uint8_t* at = p_ + pos_;
    pos_ += k;
    return at;
  }
  void bytes(uint8_t* to, size_t k) {
    need(k);
    if (k) std::memcpy(to, p_ + pos_, k);  // an empty vector's data() may be null
    pos_ += k;
  }
  size_t pos() const { return pos_; }

 private:
  void need(size_t k) {
    if (pos_ + k > n_)
      throw WireError(std::string(what_) + ": truncated at byte " + std::to_string(pos_) + " of " +
                      std::to_string(n_));
  }
  const uint8_t* p_;
  size_t n_, pos_ = 0;
  const char* what_;
};

// CRC-32 (libdeflate) of a, then b.
inline uint32_t crc(const uint8_t* a, size_t na, const uint8_t* b = nullptr, size_t nb = 0) {
  uint32_t c = libdeflate_crc32(0, a, na);
  if (nb) c = libdeflate_crc32(c, b, nb);
  return c;
}

}  // namespace lf::wire_io
