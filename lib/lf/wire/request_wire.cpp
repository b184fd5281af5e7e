// View requests on the wire (lib/lf/wire/wire.h: serialize_request,
// parse_request).
#include <cmath>
#include <string>
#include <vector>

#include "lf/geometry/rotation.h"
#include "lf/wire/byte_io.h"
#include "lf/wire/wire.h"

namespace lf {

using wire_io::crc;
using wire_io::Reader;
using wire_io::Writer;

namespace {

// Bytes of a surface block (version 3), after its size field.
size_t surface_bytes(size_t planes, size_t tiles, bool second) {
  return 8 + 32 * planes + tiles * (second ? 2 : 1);
}

}  // namespace

std::vector<uint8_t> serialize_request(const ViewRequest& req) {
  validate(req);
  const FocalSurface& sf = req.surface;
  const bool second = sf.two_planes();
  const size_t tiles = sf.empty() ? 0 : static_cast<size_t>(sf.cols) * sf.rows;
  const size_t block = sf.empty() ? 0 : surface_bytes(sf.planes.size(), tiles, second);
  if (block > kMaxSurfaceBytes)
    throw std::invalid_argument("view request: focal surface of " + std::to_string(tiles) +
                                " tiles exceeds the wire limit");
  std::vector<uint8_t> out;
  out.reserve(kRequestSize + (block ? block + 4 : 0));
  Writer w(out);
  w.bytes("LFVR", 4);
  const Quilt& qt = req.quilt;
  w.u16(!qt.empty() ? 4 : sf.empty() ? 2 : 3);
  w.u16(kRequestSize);
  w.u32(req.viewer_id);
  w.u64(req.sequence);
  for (int i = 0; i < 3; ++i) w.f64(req.view.position[i]);
  const cv::Vec4d q = quaternion_from_rotation(req.view.R);
  for (int i = 0; i < 4; ++i) w.f64(q[i]);
  w.f64(req.view.vfov_deg);
  w.u16(static_cast<uint16_t>(req.view.width));
  w.u16(static_cast<uint16_t>(req.view.height));
  w.f64(req.view.shift_x);
  w.f64(req.view.shift_y);
  for (int i = 0; i < 3; ++i) w.f64(req.focal_plane.n[i]);
  w.f64(req.focal_plane.d);
  w.u8(static_cast<uint8_t>(req.aperture));
  w.u8(static_cast<uint8_t>(req.sampling));
  w.u16(req.aperture == Aperture::kUlr          ? static_cast<uint16_t>(req.ulr_cameras)
        : req.aperture == Aperture::kFourCamera ? 0
                                                : aperture_scale_q8(req.aperture_scale));
  w.u64(static_cast<uint64_t>(req.time_ns < 0 ? -1 : req.time_ns));
  if (!sf.empty()) {
    w.u32(static_cast<uint32_t>(block));
    w.u16(static_cast<uint16_t>(sf.tile));
    w.u16(static_cast<uint16_t>(sf.cols));
    w.u16(static_cast<uint16_t>(sf.rows));
    w.u8(static_cast<uint8_t>(sf.planes.size()));
    w.u8(second ? 1 : 0);
    for (const FocalPlane& p : sf.planes) {
      for (int i = 0; i < 3; ++i) w.f64(p.n[i]);
      w.f64(p.d);
    }
    w.bytes(sf.plane_of.data(), sf.plane_of.size());
    if (second) w.bytes(sf.second_of.data(), sf.second_of.size());
  }
  if (!qt.empty()) {
    w.u32(kQuiltBlockSize);
    w.u8(static_cast<uint8_t>(qt.views));
    w.u8(static_cast<uint8_t>(qt.cols));
    w.u8(static_cast<uint8_t>(qt.rows));
    w.u8(0);
    w.f64(qt.baseline);
  }
  w.u32(crc(out.data(), out.size()));
  return out;
}

uint16_t aperture_scale_q8(double scale) {
  if (!(scale >= 1.0 && scale <= kMaxApertureScale))
    throw std::invalid_argument("view request: aperture scale " + std::to_string(scale) +
                                " is outside 1.." +
                                std::to_string(static_cast<int>(kMaxApertureScale)));
  const long q = std::lround(scale * 256.0);
  return static_cast<uint16_t>(q <= 256 ? 0 : q);
}

ViewRequest parse_request(const uint8_t* data, size_t size) {
  auto bad = [](const std::string& what) { throw WireError("view request: " + what); };
  if (data == nullptr && size > 0) bad("null buffer");
  if (size < kRequestSize)
    bad("truncated (" + std::to_string(size) + " of " + std::to_string(kRequestSize) + " bytes)");
  if (std::memcmp(data, "LFVR", 4) != 0) bad("bad magic (not an lf view request)");
  Reader r(data, size, "view request");
  for (int i = 0; i < 4; ++i) r.u8();
  const uint16_t version = r.u16();
  if (version < 2 || version > 4)
    bad("unsupported version " + std::to_string(version) + " (this build speaks versions 2..4)");
  const uint16_t fixed = r.u16();
  if (fixed != kRequestSize || (version == 2 && size != kRequestSize))
    bad("size " + std::to_string(size) + " (announced " + std::to_string(fixed) + "), expected " +
        std::to_string(kRequestSize));
  ViewRequest req;
  req.viewer_id = r.u32();
  req.sequence = r.u64();
  for (int i = 0; i < 3; ++i) req.view.position[i] = r.f64();
  cv::Vec4d q;
  for (int i = 0; i < 4; ++i) q[i] = r.f64();
  req.view.vfov_deg = r.f64();
  req.view.width = r.u16();
  req.view.height = r.u16();
  req.view.shift_x = r.f64();
  req.view.shift_y = r.f64();
  for (int i = 0; i < 3; ++i) req.focal_plane.n[i] = r.f64();
  req.focal_plane.d = r.f64();
  const uint8_t ap = r.u8();
  const uint8_t sampling = r.u8();
  const uint16_t scale_q8 = r.u16();
  req.time_ns = static_cast<int64_t>(r.u64());
  if (version == 4) {
    const uint32_t block = r.u32();
    if (block != kQuiltBlockSize || size != kRequestSize + kQuiltBlockSize + 4)
      bad("quilt block of " + std::to_string(block) + " bytes in " + std::to_string(size) +
          " (expected " + std::to_string(kQuiltBlockSize) + " in " +
          std::to_string(kRequestSize + kQuiltBlockSize + 4) + ")");
    Reader tail(data + size - 4, 4, "view request");
    if (crc(data, size - 4) != tail.u32()) bad("CRC mismatch (corrupt data)");
    req.quilt.views = r.u8();
    req.quilt.cols = r.u8();
    req.quilt.rows = r.u8();
    if (r.u8() != 0) bad("unknown quilt flags");
    req.quilt.baseline = r.f64();
    if (req.quilt.views < 2) bad("a quilt of " + std::to_string(req.quilt.views) + " views");
  } else if (version == 3) {
    // The surface block: its size first, checked against what came and the
    // limit, then the CRC over all of it, before anything is allocated.
    const uint32_t block = r.u32();
    if (block > kMaxSurfaceBytes || block < surface_bytes(1, 1, false))
      bad("focal surface block of " + std::to_string(block) + " bytes (1.." +
          std::to_string(kMaxSurfaceBytes) + ")");
    if (size != kRequestSize + block + 4)
      bad("size " + std::to_string(size) + ", expected " +
          std::to_string(kRequestSize + block + 4) + " for its focal surface");
    Reader tail(data + size - 4, 4, "view request");
    if (crc(data, size - 4) != tail.u32()) bad("CRC mismatch (corrupt data)");
    FocalSurface& sf = req.surface;
    sf.tile = r.u16();
    sf.cols = r.u16();
    sf.rows = r.u16();
    const size_t planes = r.u8();
    const uint8_t flags = r.u8();
    if (flags > 1) bad("unknown focal surface flags " + std::to_string(flags));
    const bool second = flags == 1;
    const size_t tiles = static_cast<size_t>(sf.cols) * sf.rows;
    if (planes < 1 || planes > static_cast<size_t>(FocalSurface::kMaxPlanes) ||
        block != surface_bytes(planes, tiles, second))
      bad("focal surface of " + std::to_string(planes) + " planes and " + std::to_string(sf.cols) +
          " x " + std::to_string(sf.rows) + " tiles does not fill its " + std::to_string(block) +
          " bytes");
    sf.planes.resize(planes);
    for (FocalPlane& p : sf.planes) {
      for (int i = 0; i < 3; ++i) p.n[i] = r.f64();
      p.d = r.f64();
    }
    sf.plane_of.resize(tiles);
    r.bytes(sf.plane_of.data(), tiles);
    if (second) {
      sf.second_of.resize(tiles);
      r.bytes(sf.second_of.data(), tiles);
      if (!sf.two_planes()) bad("focal surface flags second planes but names none");
    }
  } else {
    const uint32_t sum = r.u32();
    if (crc(data, kRequestSize - 4) != sum) bad("CRC mismatch (corrupt data)");
  }
  if (sampling > 1) bad("unknown sampling filter " + std::to_string(sampling));
  req.sampling = static_cast<Sampling>(sampling);
  if (req.time_ns < -1) bad("time " + std::to_string(req.time_ns) + " ns is negative");
  if (ap > 2) bad("unknown aperture " + std::to_string(ap));
  if (ap == 2) {
    if (scale_q8 != 0) bad("four-camera weights have no scale");
    req.aperture = Aperture::kFourCamera;
  } else if (ap == 1) {
    req.aperture = Aperture::kUlr;
    req.ulr_cameras = scale_q8;  // checked by validate() below
  } else {
    if (scale_q8 != 0 && (scale_q8 <= 256 || scale_q8 > 256 * kMaxApertureScale))
      bad("aperture scale " + std::to_string(scale_q8) + "/256 is outside (1, " +
          std::to_string(static_cast<int>(kMaxApertureScale)) + "] (0: the tent)");
    req.aperture_scale = scale_q8 == 0 ? 1.0 : scale_q8 / 256.0;
  }
  const double qn = cv::norm(q);
  if (!std::isfinite(qn) || std::abs(qn - 1.0) > 1e-6) bad("orientation quaternion is not unit");
  req.view.R = rotation_from_quaternion(q);
  try {
    validate(req);
  } catch (const std::invalid_argument& e) {
    throw WireError(e.what());
  }
  return req;
}

}  // namespace lf
