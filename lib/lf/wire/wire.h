// Wire formats for fragments and view requests: one serializer and one
// validating parser shared by senders and receivers (metas do not survive
// RTP, so everything a receiver needs travels in band).
//
// All integers and IEEE-754 doubles are big-endian (network order). Every
// message ends with (fragment: its header ends with) a CRC-32 (zlib) over the
// header and the payload, so corruption is detected, not rendered.
//
// A camera's answer to a request whose focal surface has second planes is
// its layer-0 fragment followed by its layer-1 fragment (byte 46 below) in
// one buffer: the first's header gives its size (56 + payload_size), the
// second starts there and must be the same viewer, request and camera
// (gst/lfcompositor.cpp checks this). Everything else is one fragment a
// buffer.
//
// Fragment, version 1: 56-byte header
//   0  "LFFR"            4 bytes magic
//   4  version  u16      = 1
//   6  header   u16      = 56
//   8  viewer_id u32, 12 sequence u64, 20 camera_id u32, 24 capture_time_ns i64
//  32  out_width u16, 34 out_height u16 (the output frame, 1..16384)
//  36  rect x, y, w, h  u16 x 4 (inside the output frame; all 0 when empty)
//  44  encoding u8 (0 empty, 1 raw, 2 jpeg), 45 jpeg quality u8 (1..100 with
//      jpeg, else 0), 46 layer u8 (0, or 1: the second planes of a focal
//      surface's two-plane tiles, fragment.h), 47 reserved u8 (0)
//  48  payload_size u32 (<= 64 MiB), 52 crc32 u32 (bytes 0..51, then payload)
// Fragment, version 2: a partial sum (fragment.h Fragment::cameras and
// weight_shift; lf/render/composite.h sum_fragments), 60-byte header: bytes 0..51
// as version 1 (version = 2, header = 60), then 52 cameras u16 (1..4096,
// the cameras whose pixels it sums; the compositor counts them towards a
// complete request), 54 weight_shift u8 (0..8: each pixel value is the
// sum >> shift, rounded), 55 flags u8 (1: the spans are deflated), 56
// crc32 u32 (bytes 0..55, then payload). With flag 1 the payload's row
// spans are replaced by: size N u32, then N bytes of raw DEFLATE (RFC 1951)
// that inflate to exactly 4 * rect.h bytes: per row the begin and end
// minus the row before's (u16 mod 2^16, the first row's minus 0); the
// rest of the payload follows as in version 1. serialize_fragment writes
// version 1 whenever cameras is 1 and the shift 0, so single cameras'
// bytes are as before, and deflates a sum's spans (a sum's edges are
// nearly straight: 4 bytes a row become a few bytes in all).
// Payload: rect.h row spans (u16 begin, u16 end, relative to rect.x, begin <=
// end <= w), then
//   raw:  the span pixels, 4 bytes each, row after row;
//   jpeg: flags u8 (1: the JPEGs leave out their DQT and DHT segments, which
//         are then libjpeg's standard tables for the quality in byte 45, ITU
//         T.81 Annex K, put back by the receiver after SOI, as RTP/JPEG, RFC
//         2435, does; 2: the weight JPEG is at half resolution, (w+1)/2 x
//         (h+1)/2, upsampled bilinearly), colour_size u32, then a baseline
//         YCbCr 4:2:0 JPEG of the w x h rectangle's colour (colour_size
//         bytes), then a greyscale JPEG of its fourth channel (the weight,
//         the rest of the payload). Pixels outside the spans are ignored (the
//         sender fills them from the nearest span pixels).
//
// View request, version 2: 152 bytes
//   0 "LFVR", 4 version u16 = 2, 6 size u16 = 152, 8 viewer_id u32, 12 sequence u64,
//  20 position f64 x 3, 44 orientation quaternion (w, x, y, z) f64 x 4 (world -> view,
//     unit within 1e-6), 76 vfov_deg f64, 84 width u16, 86 height u16,
//  88 shift_x f64, 96 shift_y f64, 104 focal plane n f64 x 3, 128 d f64,
// 136 aperture u8 (0: tent, 1: ULR, 2: four-camera), 137 sampling u8 (view.h
// Sampling: 0 bilinear, 1 bicubic), 138 aperture parameter u16: with ULR its k
// (2..16), four-camera 0, with the tent its scale
// in 1/256 (view.h Aperture: 0 for the paper's tent, scale 1, else
// 257..4096, scales (1, 16]; serialize_request rounds to the nearest 1/256),
// 140 time_ns i64 (>= -1), 148 crc32 u32 (bytes 0..147). Version 1 (144
// bytes, no time) is refused.
//
// View request, version 3: a request with a focal surface (view.h
// FocalSurface; serialize_request writes version 2 when it has none). Bytes
// 0..147 as version 2 (version = 3, size = 152: the fixed part), then
// 148 surface_size S u32 (the bytes from 152 to the CRC), 152 tile u16,
// 154 cols u16, 156 rows u16, 158 planes P u8 (1..64), 159 flags u8 (0, or
// 1: second planes follow), 160 P planes (n f64 x 3, d f64: 32 bytes
// each), then cols * rows plane indices u8 (row-major), with flag 1 then
// cols * rows second-plane indices u8 (255: none; view.h
// FocalSurface::second_of), then crc32 u32 over everything before it.
// S = 8 + 32 P + cols * rows (x 2 with flag 1), at most kMaxSurfaceBytes (the grid is checked
// against the view before anything is allocated: a peer cannot make the
// parser allocate more than it sent).
//
// View request, version 4: a quilt request (view.h ViewRequest::quilt,
// lf/render/quilt.h; never with a focal surface). Bytes 0..147 as version 2
// (version = 4, size = 152), then 148 block size u32 = 12, 152 views u8
// (2..128), 153 cols u8, 154 rows u8, 155 flags u8 (0), 156 baseline f64
// (rig units), 164 crc32 u32 (bytes 0..163): 168 bytes. A camera answers it
// with its fragment of each eye it sees, back to back in one buffer, each
// a rectangle of the quilt frame (out_width x out_height the quilt's), all
// layer 0, of the same viewer, request and camera; or one empty fragment
// when it sees none.
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <vector>

#include "lf/geometry/view.h"
#include "lf/render/fragment.h"

namespace lf {

enum class Encoding : uint8_t { kEmpty = 0, kRaw = 1, kJpeg = 2 };

// Thrown by the parsers; the message names the field and what is wrong.
struct WireError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

constexpr size_t kFragmentHeaderSize = 56;     // version 1
constexpr size_t kSumFragmentHeaderSize = 60;  // version 2 (a partial sum)
constexpr size_t kRequestSize = 152;           // version 2 (no focal surface)
// Version 3's surface block: 16384 x 16384 pixels in tiles of 16, or
// 4096 x 4096 in tiles of 4 (1 MiB).
constexpr size_t kMaxSurfaceBytes = 8 + 32 * 64 + (size_t{1} << 20);
// Version 4's quilt block (after its size field).
constexpr size_t kQuiltBlockSize = 12;
constexpr size_t kMaxPayload = 64u << 20;
// Default cap on a parsed fragment's rectangle: 8192 x 8192 pixels.
constexpr size_t kMaxFragmentPixels = size_t{8192} * 8192;

// Serializes a fragment (empty fragments are always sent as kEmpty).
// jpeg_quality in 1..100. Throws std::invalid_argument on an inconsistent
// fragment.
std::vector<uint8_t> serialize_fragment(const Fragment& f, Encoding encoding,
                                        int jpeg_quality = 90);
// A JPEG fragment whose pixels were drawn straight into the rectangle the
// encoder takes (lf/render/render.h render_rows with row_bytes = 4 * rect.width),
// with no copy of them: `f` has the header fields, rect and spans (its
// `pixels` empty, as describe_fragment leaves them); `rect_rgba` holds
// rect.width x rect.height RGBA pixels, the span pixels in place, and is
// written to (the pixels outside the spans become the encoder's padding).
// The same bytes as serialize_fragment(f with the span pixels, kJpeg,
// jpeg_quality); the same exceptions, and std::invalid_argument for an `f`
// with pixels.
std::vector<uint8_t> serialize_jpeg_fragment(const Fragment& f, uint8_t* rect_rgba,
                                             int jpeg_quality = 90);
// Parses and validates; the result passes check_fragment(). `encoding`
// receives the payload's encoding if not null. A fragment whose rectangle has
// more than `max_pixels` pixels is rejected before anything is decoded (a
// receiver passes the area of the frame it composites, so a peer cannot make
// it decode more than that); JPEG decoding also limits progressive scans
// (TurboJPEG's TJFLAG_LIMITSCANS), so its cost is bounded by the pixels.
Fragment parse_fragment(const uint8_t* data, size_t size, Encoding* encoding = nullptr,
                        size_t max_pixels = kMaxFragmentPixels);

// Parses and validates as parse_fragment() does (the CRC included), but a
// raw payload's pixels are not copied: the result's `pixels` stays empty and
// *pixels points at them inside `data` (4 bytes per span pixel, row after
// row; valid as long as `data` is). JPEG payloads are decoded into the
// result's `pixels`, and *pixels points there. Empty fragments: nullptr.
// Composite with Compositor::add(f, *pixels) (lf/render/composite.h).
// check_crc false skips the CRC (only): for bytes sealed in this process
// that never left it (gst/lfmeta.h LfSealedMeta), never for received ones.
Fragment parse_fragment_in_place(const uint8_t* data, size_t size, const uint8_t** pixels,
                                 Encoding* encoding = nullptr,
                                 size_t max_pixels = kMaxFragmentPixels, bool check_crc = true);

// Decodes a JPEG fragment straight into the raw wire format, for a receiver
// that composites raw fragments in place: parses and validates as
// parse_fragment() does (the CRC, the max_pixels limit before decoding),
// decodes, then asks out(size) for `size` bytes and writes there exactly
// the bytes serialize_fragment(f, Encoding::kRaw) gives for the decoded
// fragment f, sealed (seal_fragment). Returns f's header fields, rect and
// spans (its `pixels` empty). `out` is not called for a fragment that fails
// before it is decoded; if it throws, the exception goes on. Throws WireError
// as parse_fragment() does, std::invalid_argument for a fragment that is not
// JPEG.
Fragment decode_jpeg_to_raw(const uint8_t* data, size_t size, size_t max_pixels,
                            const std::function<uint8_t*(size_t)>& out);

// Raw fragments serialised in place, for a sender that renders the pixels
// straight into its output buffer (no copy of them; lf/render/render.h:
// describe_fragment, render_pixels):
//  * raw_fragment_size(f): the bytes f takes (its header fields, rect and
//    spans are read, f.pixels is not; empty fragments: the header alone);
//  * write_raw_fragment(f, out, size): writes the header (CRC 0) and the
//    spans into `out`, exactly raw_fragment_size(f) bytes, and returns where
//    the pixels go (4 bytes per span pixel, row after row);
//  * seal_fragment(out, size): once the pixels are there, writes the CRC.
// The bytes then equal serialize_fragment(f, Encoding::kRaw) of the fragment
// with those pixels. Throw std::invalid_argument on an inconsistent fragment
// or a size that does not match.
size_t raw_fragment_size(const Fragment& f);
uint8_t* write_raw_fragment(const Fragment& f, uint8_t* out, size_t size);
void seal_fragment(uint8_t* out, size_t size);

// The identifying header fields of a serialized fragment, read without
// checking the CRC or decoding the payload (for routing and tracing).
// Throws WireError on a truncated buffer, bad magic, version or header size,
// and (version 2) a camera count or weight shift out of range.
struct FragmentHeader {
  uint32_t viewer_id = 0;
  uint64_t sequence = 0;
  uint32_t camera_id = 0;
  int64_t capture_time_ns = -1;
  Encoding encoding = Encoding::kEmpty;
  uint8_t layer = 0;
  uint32_t payload_size = 0;
  uint16_t header_size = kFragmentHeaderSize;  // 56, or 60 for a partial sum
  uint16_t cameras = 1;
  uint8_t weight_shift = 0;
  bool deflated_spans = false;  // version 2: the spans are deflated
  // The whole fragment's bytes: header and payload.
  size_t size() const { return size_t{header_size} + payload_size; }
};
FragmentHeader peek_fragment_header(const uint8_t* data, size_t size);

// A request's aperture scale on the wire (bytes 138..139): 0 for 1 (the
// tent, as before the field existed), else round(256 * scale). Throws
// std::invalid_argument outside 1..kMaxApertureScale.
uint16_t aperture_scale_q8(double scale);

// Version 2, 3 with a focal surface, 4 with a quilt. Throws std::invalid_argument on a
// request lf::validate() refuses or a surface over kMaxSurfaceBytes.
std::vector<uint8_t> serialize_request(const ViewRequest& r);
// Parses and validates (including lf::validate()); versions 2 to 4.
ViewRequest parse_request(const uint8_t* data, size_t size);

}  // namespace lf
