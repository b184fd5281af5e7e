// A JPEG stream's marker segments (ITU T.81 Annex B), for the JPEG
// fragments' table elision (lib/lf/wire/wire.cpp): internal to
// lib/lf/wire, not installed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace lf::wire_io {

// Walks a JPEG's segments up to its scan: on(table, p, n) for SOI (a
// non-table part), each marker segment (DQT and DHT are tables), then the
// scan to the end (a non-table part). False if the stream is not laid out as
// expected.
template <typename On>
bool walk_segments(const uint8_t* j, size_t n, On&& on) {
  if (n < 4 || j[0] != 0xFF || j[1] != 0xD8) return false;
  on(false, j, 2);
  size_t pos = 2;
  while (pos + 4 <= n) {
    if (j[pos] != 0xFF) return false;
    const uint8_t m = j[pos + 1];
    if (m == 0xDA) {  // start of scan: the rest is entropy-coded data
      on(false, j + pos, n - pos);
      return true;
    }
    const size_t len = (size_t{j[pos + 2]} << 8) | j[pos + 3];
    if (len < 2 || pos + 2 + len > n) return false;
    on(m == 0xDB || m == 0xC4, j + pos, 2 + len);
    pos += 2 + len;
  }
  return false;
}

// The DQT + DHT segments of a JPEG, back to back (false: not laid out as
// expected).
inline bool tables_of(const uint8_t* j, size_t n, std::vector<uint8_t>& tables) {
  tables.clear();
  return walk_segments(j, n, [&](bool table, const uint8_t* p, size_t k) {
    if (table) tables.insert(tables.end(), p, p + k);
  });
}

}  // namespace lf::wire_io
