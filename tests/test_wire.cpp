// Wire formats: round trips, and rejection of truncated, corrupt, oversized
// and inconsistent input (never a crash, always a WireError naming the field).
#include <gtest/gtest.h>
#include <zlib.h>

#include <functional>
#include <opencv2/core.hpp>
#include <random>

#include "lf/focus/focus.h"
#include "lf/focus/surface_probe.h"
#include "lf/geometry/view_builder.h"
#include "lf/io/parse.h"
#include "lf/quality/quality.h"
#include "lf/quality/synthetic.h"
#include "lf/render/composite.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"
#include "lf/wire/probe_bundle.h"
#include "lf/wire/rtp_guard.h"
#include "lf/wire/wire.h"

namespace {

lf::Fragment sample_fragment() {
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 50);
  lf::ViewRequest req;
  req.viewer_id = 7;
  req.sequence = 123456789012ull;
  req.view = lf::VirtualView::look_at({0.1, 0.1, -1}, {0, 0, 10}, {0, 1, 0}, 40, 160, 120);
  req.focal_plane = lf::FocalPlane::through({0, 0, 10}, {0, 0, 1});
  const lf::ViewGeometry g(rig, req);
  lf::Fragment f;
  f.viewer_id = req.viewer_id;
  f.sequence = req.sequence;
  f.capture_time_ns = 987654321;
  lf::render_fragment(lf::plan_fragment(g, 4), rig.cameras[4],
                      lf::render_textured_plane(rig.cameras[4], 10, 1.0), f);
  return f;
}

lf::ViewRequest sample_request() {
  lf::ViewRequest r;
  r.viewer_id = 3;
  r.sequence = 42;
  r.view = lf::VirtualView::look_at({0.1, -0.2, 0.3}, {1, 2, 10}, {0, 1, 0}, 47.5, 640, 480);
  r.view.shift_x = 3.25;
  r.view.shift_y = -1.5;
  r.focal_plane = lf::FocalPlane::through({0, 0, 7}, {0.1, 0.2, 1});
  r.time_ns = 1234567890123;
  return r;
}

// Rewrites the CRC so that semantic checks (not the checksum) must catch a change.
void resign_fragment(std::vector<uint8_t>& b) {
  uLong c = crc32(0L, Z_NULL, 0);
  c = crc32(c, b.data(), 52);
  c = crc32(c, b.data() + 56, static_cast<uInt>(b.size() - 56));
  for (int i = 0; i < 4; ++i) b[52 + i] = static_cast<uint8_t>(c >> (24 - 8 * i));
}
void put16(std::vector<uint8_t>& b, size_t at, uint16_t v) {
  b[at] = v >> 8, b[at + 1] = v & 0xff;
}

TEST(Wire, RawFragmentRoundTrip) {
  const lf::Fragment f = sample_fragment();
  ASSERT_FALSE(f.empty());
  const auto bytes = lf::serialize_fragment(f, lf::Encoding::kRaw);
  lf::Encoding enc;
  const lf::Fragment g = lf::parse_fragment(bytes.data(), bytes.size(), &enc);
  EXPECT_EQ(enc, lf::Encoding::kRaw);
  EXPECT_EQ(g.viewer_id, f.viewer_id);
  EXPECT_EQ(g.sequence, f.sequence);
  EXPECT_EQ(g.camera_id, f.camera_id);
  EXPECT_EQ(g.capture_time_ns, f.capture_time_ns);
  EXPECT_EQ(g.rect, f.rect);
  EXPECT_EQ(g.out_width, f.out_width);
  EXPECT_EQ(g.spans, f.spans);
  EXPECT_EQ(g.pixels, f.pixels);
  EXPECT_EQ(g.layer, 0);
  // A second-plane fragment says so (byte 46), in full and when peeked.
  lf::Fragment f1 = f;
  f1.layer = 1;
  const auto b1 = lf::serialize_fragment(f1, lf::Encoding::kRaw);
  EXPECT_EQ(b1[46], 1);
  EXPECT_EQ(lf::parse_fragment(b1.data(), b1.size()).layer, 1);
  EXPECT_EQ(lf::peek_fragment_header(b1.data(), b1.size()).layer, 1);
}

// Serialising in place (header and spans, pixels rendered straight into
// the buffer, then sealed) gives the bytes that serialize_fragment() gives.
TEST(Wire, InPlaceRawFragmentEqualsSerialized) {
  lf::Fragment f = sample_fragment();
  lf::Fragment empty;
  empty.viewer_id = 2, empty.sequence = 9, empty.camera_id = 3;
  empty.out_width = 160, empty.out_height = 120;
  for (const lf::Fragment* src : {&f, &empty}) {
    const auto want = lf::serialize_fragment(*src, lf::Encoding::kRaw);
    lf::Fragment geo = *src;
    geo.pixels.clear();  // not read
    const size_t size = lf::raw_fragment_size(geo);
    ASSERT_EQ(size, want.size());
    std::vector<uint8_t> out(size, 0xcd);
    uint8_t* px = lf::write_raw_fragment(geo, out.data(), out.size());
    ASSERT_EQ(static_cast<size_t>(out.data() + out.size() - px), src->pixels.size());
    std::copy(src->pixels.begin(), src->pixels.end(), px);
    lf::seal_fragment(out.data(), out.size());
    EXPECT_EQ(out, want);
    EXPECT_THROW(lf::write_raw_fragment(geo, out.data(), out.size() - 1), std::invalid_argument);
  }
  lf::Fragment bad = f;
  bad.spans.pop_back();
  EXPECT_THROW(lf::raw_fragment_size(bad), std::invalid_argument);
}

// Parsing in place: raw pixels are pointed to inside the buffer, not copied;
// every check still runs, and only the CRC can be waived.
TEST(Wire, InPlaceParsingPointsIntoTheBuffer) {
  const lf::Fragment f = sample_fragment();
  auto bytes = lf::serialize_fragment(f, lf::Encoding::kRaw);
  const uint8_t* px = nullptr;
  lf::Encoding enc;
  const lf::Fragment g = lf::parse_fragment_in_place(bytes.data(), bytes.size(), &px, &enc);
  EXPECT_EQ(enc, lf::Encoding::kRaw);
  EXPECT_TRUE(g.pixels.empty());
  ASSERT_EQ(px, bytes.data() + bytes.size() - f.pixels.size());
  EXPECT_TRUE(std::equal(f.pixels.begin(), f.pixels.end(), px));
  EXPECT_EQ(g.spans, f.spans);
  EXPECT_EQ(g.rect, f.rect);
  EXPECT_EQ(lf::check_fragment_geometry(g), f.pixel_count());
  EXPECT_THROW(lf::check_fragment(g), std::invalid_argument);  // its pixels are elsewhere
  EXPECT_THROW(lf::parse_fragment_in_place(bytes.data(), bytes.size(), nullptr),
               std::invalid_argument);
  // JPEG: decoded, *pixels at the result's own pixels.
  const auto jpeg = lf::serialize_fragment(f, lf::Encoding::kJpeg);
  const lf::Fragment j = lf::parse_fragment_in_place(jpeg.data(), jpeg.size(), &px, &enc);
  EXPECT_EQ(enc, lf::Encoding::kJpeg);
  EXPECT_EQ(px, j.pixels.data());
  EXPECT_EQ(j.pixels.size(), f.pixels.size());
  // A flipped pixel bit: caught by the CRC, passed when the CRC is waived
  // (bytes sealed in this process); a bad span is caught either way.
  bytes[bytes.size() - 3] ^= 0x10;
  EXPECT_THROW(lf::parse_fragment_in_place(bytes.data(), bytes.size(), &px), lf::WireError);
  EXPECT_NO_THROW(lf::parse_fragment_in_place(bytes.data(), bytes.size(), &px, nullptr,
                                              lf::kMaxFragmentPixels, false));
  put16(bytes, 56, 0xffff);  // first span's begin beyond the rectangle
  EXPECT_THROW(lf::parse_fragment_in_place(bytes.data(), bytes.size(), &px, nullptr,
                                           lf::kMaxFragmentPixels, false),
               lf::WireError);
  // Compositing the borrowed pixels equals compositing a copy.
  lf::Compositor a, b;
  a.reset(f.out_width, f.out_height);
  b.reset(f.out_width, f.out_height);
  const auto good = lf::serialize_fragment(f, lf::Encoding::kRaw);
  const lf::Fragment h = lf::parse_fragment_in_place(good.data(), good.size(), &px);
  a.add(h, px);
  b.add(f);
  cv::Mat ra, rb;
  a.resolve(ra);
  b.resolve(rb);
  EXPECT_EQ(cv::norm(ra, rb, cv::NORM_INF), 0);
  cv::Mat alpha;
  cv::extractChannel(ra, alpha, 3);
  EXPECT_GT(static_cast<size_t>(cv::countNonZero(alpha)), f.pixel_count() / 2);
  EXPECT_THROW(a.add(h, nullptr), std::invalid_argument);
}

TEST(Wire, JpegFragmentRoundTrip) {
  const lf::Fragment f = sample_fragment();
  const auto raw = lf::serialize_fragment(f, lf::Encoding::kRaw);
  const auto jpg = lf::serialize_fragment(f, lf::Encoding::kJpeg, 90);
  EXPECT_LT(jpg.size(), raw.size() / 3);
  lf::Encoding enc;
  const lf::Fragment g = lf::parse_fragment(jpg.data(), jpg.size(), &enc);
  EXPECT_EQ(enc, lf::Encoding::kJpeg);
  EXPECT_EQ(g.spans, f.spans);
  ASSERT_EQ(g.pixels.size(), f.pixels.size());
  double se = 0, alpha_err = 0;
  for (size_t i = 0; i < f.pixels.size(); ++i) {
    const double d = double(g.pixels[i]) - f.pixels[i];
    se += d * d;
    if (i % 4 == 3) alpha_err = std::max(alpha_err, std::abs(d));
  }
  const double psnr = 10 * std::log10(255.0 * 255.0 * f.pixels.size() / se);
  EXPECT_GT(psnr, 38.0);
  EXPECT_LE(alpha_err, 6.0);  // the weight channel survives q90 closely
}

// A JPEG fragment serialised from the rectangle its pixels were drawn into
// (lffragment's CPU path): the same bytes as from the fragment, whatever
// the rectangle holds outside the spans; single cameras and partial sums.
TEST(Wire, JpegFromTheRectangleEqualsSerialized) {
  lf::Fragment f = sample_fragment();
  const int w = f.rect.width, h = f.rect.height;
  int partial_rows = 0;
  for (const bool sum : {false, true}) {
    if (sum) f.cameras = 16, f.weight_shift = 2;
    for (const int q : {50, 90}) {
      lf::Fragment head = f;
      head.pixels.clear();
      std::vector<uint8_t> rect(4 * static_cast<size_t>(w) * h, 0x5a);
      const uint8_t* src = f.pixels.data();
      for (int r = 0; r < h; ++r) {
        const int b = f.spans[r][0] - f.rect.x, e = f.spans[r][1] - f.rect.x;
        std::copy(src, src + 4 * (e - b), rect.begin() + 4 * (static_cast<size_t>(r) * w + b));
        src += 4 * (e - b);
        partial_rows += e - b < w;
      }
      EXPECT_EQ(lf::serialize_jpeg_fragment(head, rect.data(), q),
                lf::serialize_fragment(f, lf::Encoding::kJpeg, q))
          << (sum ? "partial sum" : "one camera") << ", quality " << q;
      std::vector<uint8_t> any(rect.size(), 0);
      EXPECT_THROW(lf::serialize_jpeg_fragment(f, any.data(), q), std::invalid_argument)
          << "a fragment with pixels";
      EXPECT_THROW(lf::serialize_jpeg_fragment(head, rect.data(), 0), std::invalid_argument);
    }
  }
  EXPECT_GT(partial_rows, 8) << "the padding outside the spans is exercised";
  lf::Fragment empty = sample_fragment();
  empty.rect = cv::Rect();
  empty.spans.clear();
  empty.pixels.clear();
  EXPECT_EQ(lf::serialize_jpeg_fragment(empty, nullptr, 90),
            lf::serialize_fragment(empty, lf::Encoding::kJpeg, 90));
}

// Alpha error (max) and flags byte of a JPEG round trip.
std::pair<double, uint8_t> jpeg_alpha_error(const lf::Fragment& f, size_t* size = nullptr) {
  const auto b = lf::serialize_fragment(f, lf::Encoding::kJpeg, 90);
  if (size) *size = b.size();
  const lf::Fragment g = lf::parse_fragment(b.data(), b.size());
  double worst = 0;
  for (size_t i = 3; i < f.pixels.size(); i += 4)
    worst = std::max(worst, std::abs(double(g.pixels[i]) - f.pixels[i]));
  return {worst, b[lf::kFragmentHeaderSize + 4 * f.rect.height]};
}

TEST(Wire, JpegWeightResolutionFollowsItsSmoothness) {
  // A smooth weight (the sample: a fragment inside its camera's image) goes
  // at half resolution and comes back within 5 levels (2 %; creases are
  // smoothed by the 2x2 means); the standard tables
  // are left out.
  lf::Fragment f = sample_fragment();
  size_t smooth_size = 0;
  const auto [smooth_err, smooth_flags] = jpeg_alpha_error(f, &smooth_size);
  EXPECT_EQ(smooth_flags, 3);  // tables omitted | half-resolution weight
  EXPECT_LE(smooth_err, 5.0);
  // A step (the camera's image border crossing the fragment) forces full
  // resolution: the weight then stays within JPEG's error at q90.
  size_t n = 0;
  for (int r = 0; r < f.rect.height; ++r)
    for (int x = f.spans[r][0]; x < f.spans[r][1]; ++x, ++n)
      if (x < f.rect.x + f.rect.width / 2) f.pixels[4 * n + 3] = 0;
  const auto [step_err, step_flags] = jpeg_alpha_error(f);
  EXPECT_EQ(step_flags, 1);
  EXPECT_LE(step_err, 8.0);
}

TEST(Wire, JpegDecodesStraightToRaw) {
  // The raw wire bytes of the decoded fragment, written where asked, sealed:
  // equal to serialising what parse_fragment() decodes.
  const lf::Fragment f = sample_fragment();
  for (int quality : {50, 90}) {
    const auto jpeg = lf::serialize_fragment(f, lf::Encoding::kJpeg, quality);
    const lf::Fragment decoded = lf::parse_fragment(jpeg.data(), jpeg.size());
    const auto want = lf::serialize_fragment(decoded, lf::Encoding::kRaw);
    std::vector<uint8_t> got;
    const lf::Fragment head =
        lf::decode_jpeg_to_raw(jpeg.data(), jpeg.size(), lf::kMaxFragmentPixels, [&](size_t n) {
          got.assign(n, 0xAB);
          return got.data();
        });
    EXPECT_EQ(got, want) << "quality " << quality;
    EXPECT_TRUE(head.pixels.empty());
    EXPECT_EQ(head.spans, decoded.spans);
    EXPECT_EQ(head.rect, decoded.rect);
    EXPECT_EQ(head.sequence, f.sequence);
    const lf::Fragment back = lf::parse_fragment(got.data(), got.size());  // CRC checked
    EXPECT_EQ(back.pixels, decoded.pixels);
  }
  // Nothing is asked for a fragment that fails before decoding (corrupt, over
  // the pixel limit), and only JPEG fragments are taken.
  auto jpeg = lf::serialize_fragment(f, lf::Encoding::kJpeg, 90);
  int asked = 0;
  auto out = [&](size_t n) -> uint8_t* {
    ++asked;
    static std::vector<uint8_t> sink;
    sink.resize(n);
    return sink.data();
  };
  EXPECT_THROW(lf::decode_jpeg_to_raw(jpeg.data(), jpeg.size(), f.rect.area() - 1, out),
               lf::WireError);
  jpeg[jpeg.size() - 10] ^= 0x10;
  EXPECT_THROW(lf::decode_jpeg_to_raw(jpeg.data(), jpeg.size(), lf::kMaxFragmentPixels, out),
               lf::WireError);
  const auto raw = lf::serialize_fragment(f, lf::Encoding::kRaw);
  EXPECT_THROW(lf::decode_jpeg_to_raw(raw.data(), raw.size(), lf::kMaxFragmentPixels, out),
               std::invalid_argument);
  EXPECT_EQ(asked, 0);
}

TEST(Wire, JpegTablesAreLeftOutAndPutBack) {
  // About 570 bytes of DQT/DHT per fragment do not travel.
  const lf::Fragment f = sample_fragment();
  const auto b = lf::serialize_fragment(f, lf::Encoding::kJpeg, 75);
  const size_t at = lf::kFragmentHeaderSize + 4 * f.rect.height;
  ASSERT_EQ(b[at] & 1, 1);
  const uint32_t csize = (uint32_t{b[at + 1]} << 24) | (uint32_t{b[at + 2]} << 16) |
                         (uint32_t{b[at + 3]} << 8) | b[at + 4];
  int dqt = 0, dht = 0;  // no table markers in the colour stream's header
  for (size_t i = at + 5; i + 1 < at + 5 + std::min<uint32_t>(csize, 40); ++i)
    dqt += b[i] == 0xFF && b[i + 1] == 0xDB, dht += b[i] == 0xFF && b[i + 1] == 0xC4;
  EXPECT_EQ(dqt + dht, 0);
  const lf::Fragment g = lf::parse_fragment(b.data(), b.size());
  EXPECT_EQ(g.pixels.size(), f.pixels.size());
  // A colour stream longer than the payload is an error naming it.
  auto bad = b;
  bad[at + 1] = 0x7f;
  resign_fragment(bad);
  try {
    lf::parse_fragment(bad.data(), bad.size());
    FAIL() << "accepted";
  } catch (const lf::WireError& e) {
    EXPECT_NE(std::string(e.what()).find("colour JPEG"), std::string::npos) << e.what();
  }
}

// A JPEG whose header TurboJPEG refuses (a forged fragment with one byte
// changed and its CRC made right again, as lf-hostile sends) must not
// leave this thread's decompressor unable to read the next, good one: it
// did ("Bogus marker length" for every later fragment decoded on that
// thread, which in the emulated deployment was one camera host's port).
TEST(Wire, ABadJpegDoesNotSpoilTheNextOnes) {
  const lf::Fragment f = sample_fragment();
  const auto good = lf::serialize_fragment(f, lf::Encoding::kJpeg, 90);
  const size_t at = lf::kFragmentHeaderSize + 4 * f.rect.height;
  const uint32_t csize = (uint32_t{good[at + 1]} << 24) | (uint32_t{good[at + 2]} << 16) |
                         (uint32_t{good[at + 3]} << 8) | good[at + 4];
  for (const char* stream : {"colour", "weight"}) {
    // The stream's start of scan (its tables are left out: SOI, APP0, SOF,
    // SOS), its length 8 (+ 2 per component) made 0x2xx.
    const size_t begin = std::string(stream) == "colour" ? at + 5 : at + 5 + csize;
    size_t sos = 0;
    for (size_t i = begin; i + 1 < good.size() && !sos; ++i)
      if (good[i] == 0xFF && good[i + 1] == 0xDA) sos = i;
    ASSERT_GT(sos, begin);
    auto bad = good;
    bad[sos + 2] ^= 0x02;
    resign_fragment(bad);
    for (int round = 0; round < 3; ++round) {
      try {
        lf::parse_fragment(bad.data(), bad.size());
        FAIL() << "accepted";
      } catch (const lf::WireError& e) {
        EXPECT_NE(std::string(e.what()).find(stream), std::string::npos) << e.what();
      }
      const lf::Fragment g = lf::parse_fragment(good.data(), good.size());
      EXPECT_EQ(g.pixels.size(), f.pixels.size()) << stream << " " << round;
    }
  }
}

TEST(Wire, FragmentHeaderCanBePeeked) {
  const lf::Fragment f = sample_fragment();
  const auto b = lf::serialize_fragment(f, lf::Encoding::kJpeg);
  const lf::FragmentHeader h = lf::peek_fragment_header(b.data(), b.size());
  EXPECT_EQ(h.viewer_id, f.viewer_id);
  EXPECT_EQ(h.sequence, f.sequence);
  EXPECT_EQ(h.camera_id, f.camera_id);
  EXPECT_EQ(h.capture_time_ns, f.capture_time_ns);
  EXPECT_EQ(h.encoding, lf::Encoding::kJpeg);
  EXPECT_EQ(h.payload_size, b.size() - lf::kFragmentHeaderSize);
  EXPECT_THROW(lf::peek_fragment_header(b.data(), 20), lf::WireError);
  auto bad = b;
  bad[1] = 'X';
  EXPECT_THROW(lf::peek_fragment_header(bad.data(), bad.size()), lf::WireError);
}

TEST(Wire, EmptyFragmentRoundTrip) {
  lf::Fragment f;
  f.camera_id = 9;
  f.out_width = 640;
  f.out_height = 480;
  const auto b = lf::serialize_fragment(f, lf::Encoding::kJpeg);
  EXPECT_EQ(b.size(), lf::kFragmentHeaderSize);
  lf::Encoding enc;
  const lf::Fragment g = lf::parse_fragment(b.data(), b.size(), &enc);
  EXPECT_EQ(enc, lf::Encoding::kEmpty);
  EXPECT_TRUE(g.empty());
  EXPECT_EQ(g.camera_id, 9u);
}

TEST(Wire, RequestRoundTrip) {
  const lf::ViewRequest r = sample_request();
  const auto b = lf::serialize_request(r);
  ASSERT_EQ(b.size(), lf::kRequestSize);
  const lf::ViewRequest s = lf::parse_request(b.data(), b.size());
  EXPECT_EQ(s.viewer_id, r.viewer_id);
  EXPECT_EQ(s.sequence, r.sequence);
  EXPECT_EQ(s.view.position, r.view.position);
  EXPECT_LT(cv::norm(s.view.R - r.view.R, cv::NORM_INF), 1e-15);
  EXPECT_EQ(s.view.vfov_deg, r.view.vfov_deg);
  EXPECT_EQ(s.view.width, 640);
  EXPECT_EQ(s.view.shift_x, 3.25);
  EXPECT_EQ(s.focal_plane.n, r.focal_plane.n);
  EXPECT_EQ(s.focal_plane.d, r.focal_plane.d);
  EXPECT_EQ(s.time_ns, r.time_ns);
  // Big-endian on the wire: magic then version 2.
  EXPECT_EQ(std::string(b.begin(), b.begin() + 4), "LFVR");
  EXPECT_EQ(b[4], 0);
  EXPECT_EQ(b[5], 2);
  // The tent (scale 1) is 0 in bytes 138..139, as before the field existed;
  // a wider aperture travels in 1/256 (rounded to the nearest).
  EXPECT_EQ(s.aperture_scale, 1.0);
  EXPECT_EQ(b[138] | b[139], 0);
  for (const double k : {2.5, 16.0, 1.0 + 1.0 / 256, 3.1}) {
    lf::ViewRequest a = r;
    a.aperture_scale = k;
    const auto ab = lf::serialize_request(a);
    EXPECT_EQ(lf::parse_request(ab.data(), ab.size()).aperture_scale, std::round(k * 256) / 256)
        << k;
  }
  // A ULR aperture: byte 136 = 1, its k in bytes 138..139.
  lf::ViewRequest u4 = r;
  u4.aperture = lf::Aperture::kUlr;
  u4.ulr_cameras = 5;
  const auto ub4 = lf::serialize_request(u4);
  EXPECT_EQ(ub4[136], 1);
  EXPECT_EQ(ub4[139], 5);
  const lf::ViewRequest pu = lf::parse_request(ub4.data(), ub4.size());
  EXPECT_EQ(pu.aperture, lf::Aperture::kUlr);
  EXPECT_EQ(pu.ulr_cameras, 5);
  // Four-camera weights: byte 136 = 2, bytes 138..139 zero; with a scale
  // there, or an aperture 3, the request is refused.
  lf::ViewRequest f4 = r;
  f4.aperture = lf::Aperture::kFourCamera;
  auto fb4 = lf::serialize_request(f4);
  EXPECT_EQ(fb4[136], 2);
  EXPECT_EQ(fb4[138] | fb4[139], 0);
  EXPECT_EQ(lf::parse_request(fb4.data(), fb4.size()).aperture, lf::Aperture::kFourCamera);
  auto resign = [](std::vector<uint8_t>& v) {
    const uLong c = crc32(crc32(0L, Z_NULL, 0), v.data(), 148);
    for (int i = 0; i < 4; ++i) v[148 + i] = static_cast<uint8_t>(c >> (24 - 8 * i));
  };
  ASSERT_EQ(fb4.size(), 152u);
  auto scaled = fb4;
  scaled[139] = 0x80;
  resign(scaled);
  EXPECT_THROW(lf::parse_request(scaled.data(), scaled.size()), lf::WireError);
  fb4[136] = 3;
  resign(fb4);
  EXPECT_THROW(lf::parse_request(fb4.data(), fb4.size()), lf::WireError);
  // The sampling filter: byte 137.
  lf::ViewRequest c = r;
  c.sampling = lf::Sampling::kBicubic;
  const auto cb = lf::serialize_request(c);
  EXPECT_EQ(cb[137], 1);
  EXPECT_EQ(lf::parse_request(cb.data(), cb.size()).sampling, lf::Sampling::kBicubic);
  EXPECT_EQ(s.sampling, lf::Sampling::kBilinear);
  // An unknown time travels as -1.
  lf::ViewRequest u = r;
  u.time_ns = -5;
  const auto ub = lf::serialize_request(u);
  EXPECT_EQ(lf::parse_request(ub.data(), ub.size()).time_ns, -1);
}

// A request with a focal surface of 3 planes over 40 x 30 tiles of 16.
lf::ViewRequest sample_surface_request() {
  lf::ViewRequest r = sample_request();
  lf::FocalSurface& sf = r.surface;
  sf.tile = 16, sf.cols = 40, sf.rows = 30;
  sf.planes = {lf::FocalPlane::through({0, 0, 7}, {0.1, 0.2, 1}),
               lf::FocalPlane::through({0, 0, 2.5}, {0, 0, 1}),
               lf::FocalPlane::through({0, 0, 1e6}, {0, 0, 1})};
  sf.plane_of.resize(40 * 30);
  for (size_t i = 0; i < sf.plane_of.size(); ++i) sf.plane_of[i] = static_cast<uint8_t>(i * 7 % 3);
  return r;
}

// Rewrites a version 3 request's CRC (over all but its last 4 bytes).
void resign_request3(std::vector<uint8_t>& v) {
  const uLong c = crc32(crc32(0L, Z_NULL, 0), v.data(), static_cast<uInt>(v.size() - 4));
  for (int i = 0; i < 4; ++i) v[v.size() - 4 + i] = static_cast<uint8_t>(c >> (24 - 8 * i));
}

// Expects parse() to throw a WireError whose message holds `word`.
template <class Parse>
void expect_wire_error(Parse parse, const std::string& word) {
  try {
    parse();
    ADD_FAILURE() << "accepted (" << word << ")";
  } catch (const lf::WireError& e) {
    EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
  }
}
// A version 3 request, re-signed, refused with `word`.
void expect_request_error(std::vector<uint8_t> v, const std::string& word) {
  resign_request3(v);
  expect_wire_error([&] { lf::parse_request(v.data(), v.size()); }, word);
}

// Version 3 carries the focal surface exactly; a request without one is
// still version 2, byte for byte.
TEST(Wire, FocalSurfaceRoundTrip) {
  const lf::ViewRequest r = sample_surface_request();
  const auto b = lf::serialize_request(r);
  ASSERT_EQ(b.size(), lf::kRequestSize + 8 + 3 * 32 + 40 * 30 + 4);
  EXPECT_EQ(b[5], 3);
  const lf::ViewRequest s = lf::parse_request(b.data(), b.size());
  EXPECT_EQ(s.surface.tile, 16);
  EXPECT_EQ(s.surface.cols, 40);
  EXPECT_EQ(s.surface.rows, 30);
  ASSERT_EQ(s.surface.planes.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(s.surface.planes[i].n, r.surface.planes[i].n);
    EXPECT_EQ(s.surface.planes[i].d, r.surface.planes[i].d);
  }
  EXPECT_EQ(s.surface.plane_of, r.surface.plane_of);
  EXPECT_EQ(s.time_ns, r.time_ns);
  EXPECT_EQ(s.focal_plane.d, r.focal_plane.d);
  // The same planning as the original.
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.05, 160, 120);
  lf::ViewRequest a = sample_surface_request(), c = s;
  a.view = c.view = lf::view_between_cameras(rig, rig.plane().origin, 640, 480);
  const lf::ViewGeometry ga(rig, a), gc(rig, c);
  for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i) {
    const lf::FragmentPlan pa = lf::plan_fragment(ga, i), pc = lf::plan_fragment(gc, i);
    EXPECT_EQ(pa.pixel_count(), pc.pixel_count()) << "camera " << i;
  }
  const auto v2 = lf::serialize_request(sample_request());
  EXPECT_EQ(v2.size(), lf::kRequestSize);
  EXPECT_EQ(v2[5], 2);
}

// Second planes (flag 1 in byte 159) travel after the first ones; a surface
// whose second planes are all "none" is sent without them.
TEST(Wire, SecondPlanesRoundTrip) {
  lf::ViewRequest r = sample_surface_request();
  r.surface.second_of.assign(40 * 30, lf::FocalSurface::kNone);
  const auto none = lf::serialize_request(r);
  EXPECT_EQ(none.size(), lf::kRequestSize + 8 + 3 * 32 + 40 * 30 + 4);
  EXPECT_EQ(none[159], 0);
  for (size_t i = 0; i < r.surface.second_of.size(); i += 5)
    r.surface.second_of[i] = static_cast<uint8_t>((r.surface.plane_of[i] + 1) % 3);
  auto b = lf::serialize_request(r);
  ASSERT_EQ(b.size(), lf::kRequestSize + 8 + 3 * 32 + 2 * 40 * 30 + 4);
  EXPECT_EQ(b[159], 1);
  const lf::ViewRequest s = lf::parse_request(b.data(), b.size());
  EXPECT_EQ(s.surface.plane_of, r.surface.plane_of);
  EXPECT_EQ(s.surface.second_of, r.surface.second_of);
  EXPECT_EQ(s.surface.two_plane_tiles(), 240);
  const auto refused = expect_request_error;
  auto v = b;
  v[159] = 2;
  refused(v, "flags");
  v = b;
  v[159] = 0;  // then the block is too long for its grid
  refused(v, "does not fill");
  v = b;
  const size_t second = lf::kRequestSize + 8 + 3 * 32 + 40 * 30;
  v[second] = r.surface.plane_of[0];  // a tile's second plane is its first
  refused(v, "second plane is its first");
  v = b;
  v[second + 1] = 3;  // a missing plane
  refused(v, "second plane 3");
  v = b;
  std::fill(v.begin() + second, v.end() - 4, lf::FocalSurface::kNone);
  refused(v, "names none");
}

// A surface block is checked before anything is allocated: sizes that
// disagree, a block over the limit, planes 0 or over 64, a grid that does
// not match the view, a tile naming a missing plane; at every length and
// after any corruption.
TEST(Wire, BadFocalSurfacesAreRejected) {
  const auto good = lf::serialize_request(sample_surface_request());
  for (size_t n = 0; n < good.size(); n += (n < 300 ? 1 : 53))
    EXPECT_THROW(lf::parse_request(good.data(), n), lf::WireError) << "length " << n;
  auto longer = good;
  longer.push_back(0);
  EXPECT_THROW(lf::parse_request(longer.data(), longer.size()), lf::WireError);
  for (size_t i = 0; i < good.size(); i += (i < 300 ? 1 : 31)) {
    auto b = good;
    b[i] ^= 0x5a;
    EXPECT_THROW(lf::parse_request(b.data(), b.size()), lf::WireError) << "byte " << i;
  }
  const auto expect_error = expect_request_error;
  auto put32 = [](std::vector<uint8_t>& v, size_t at, uint32_t x) {
    for (int i = 0; i < 4; ++i) v[at + i] = static_cast<uint8_t>(x >> (24 - 8 * i));
  };
  // Each change, re-signed, and a word of the error it must give.
  const size_t last = good.size() - 5;  // the last tile's plane index
  const std::vector<std::pair<std::function<void(std::vector<uint8_t>&)>, const char*>> cases = {
      {[&](auto& v) { put32(v, 148, 0x7fffffff); }, "focal surface block"},  // 2 GB announced
      {[&](auto& v) { put32(v, 148, static_cast<uint32_t>(v.size() - lf::kRequestSize - 5)); },
       "expected"},
      {[](auto& v) { v[158] = 0; }, "planes"},
      {[](auto& v) { v[158] = 65; }, "planes"},
      {[](auto& v) { v[159] = 1; }, "does not fill"},  // flags second planes: too short
      {[](auto& v) { v[159] = 2; }, "flags"},
      // 30 x 40 tiles: the same bytes, not the view's grid.
      {[](auto& v) { v[155] = 30, v[157] = 40; }, "surface"},
      {[&](auto& v) { v[last] = 3; }, "plane"}};  // plane 3 of 0..2
  for (const auto& [change, word] : cases) {
    auto v = good;
    change(v);
    expect_error(v, word);
  }
  // Too many tiles for the wire: refused when serialising.
  lf::ViewRequest big = sample_surface_request();
  big.view.width = big.view.height = 16384;
  big.surface.tile = 8, big.surface.cols = big.surface.rows = 2048;
  big.surface.plane_of.assign(2048 * 2048, 0);
  EXPECT_THROW(lf::serialize_request(big), std::invalid_argument);
}

TEST(Wire, TruncatedInputIsRejectedAtEveryLength) {
  const lf::Fragment f = sample_fragment();
  for (auto enc : {lf::Encoding::kRaw, lf::Encoding::kJpeg}) {
    const auto b = lf::serialize_fragment(f, enc);
    for (size_t n = 0; n < b.size(); n += (n < 200 ? 1 : 97))
      EXPECT_THROW(lf::parse_fragment(b.data(), n), lf::WireError) << "length " << n;
  }
  const auto r = lf::serialize_request(sample_request());
  for (size_t n = 0; n < r.size(); ++n)
    EXPECT_THROW(lf::parse_request(r.data(), n), lf::WireError) << "length " << n;
  EXPECT_THROW(lf::parse_fragment(nullptr, 0), lf::WireError);
}

TEST(Wire, CorruptionIsDetected) {
  const lf::Fragment f = sample_fragment();
  std::mt19937_64 rng(1);
  for (auto enc : {lf::Encoding::kRaw, lf::Encoding::kJpeg}) {
    const auto good = lf::serialize_fragment(f, enc);
    std::uniform_int_distribution<size_t> pos(0, good.size() - 1);
    for (int k = 0; k < 300; ++k) {
      auto b = good;
      b[pos(rng)] ^= static_cast<uint8_t>(1 + rng() % 255);
      EXPECT_THROW(lf::parse_fragment(b.data(), b.size()), lf::WireError);
    }
  }
  const auto good = lf::serialize_request(sample_request());
  for (size_t i = 0; i < good.size(); ++i) {
    auto b = good;
    b[i] ^= 0x5a;
    EXPECT_THROW(lf::parse_request(b.data(), b.size()), lf::WireError) << "byte " << i;
  }
}

TEST(Wire, OversizedAndTrailingInputIsRejected) {
  const lf::Fragment f = sample_fragment();
  auto b = lf::serialize_fragment(f, lf::Encoding::kRaw);
  auto big = b;
  big[48] = 0x7f;  // payload size ~2 GB
  resign_fragment(big);
  try {
    lf::parse_fragment(big.data(), big.size());
    FAIL() << "accepted";
  } catch (const lf::WireError& e) {
    EXPECT_NE(std::string(e.what()).find("exceeds"), std::string::npos) << e.what();
  }
  auto trailing = b;
  trailing.push_back(0);
  EXPECT_THROW(lf::parse_fragment(trailing.data(), trailing.size()), lf::WireError);
}

TEST(Wire, InconsistentFragmentsAreRejected) {
  const lf::Fragment f = sample_fragment();
  const auto good = lf::serialize_fragment(f, lf::Encoding::kRaw);
  auto expect_error = [](std::vector<uint8_t> b, const std::string& word) {
    resign_fragment(b);
    expect_wire_error([&] { lf::parse_fragment(b.data(), b.size()); }, word);
  };
  auto b = good;
  put16(b, 36, static_cast<uint16_t>(f.out_width - f.rect.width + 1));  // rect beyond frame
  expect_error(b, "exceeds the output frame");
  b = good;
  put16(b, 56, 0xffff);  // first span begins past the rectangle
  expect_error(b, "span");
  b = good;
  b[44] = 7;
  expect_error(b, "unknown encoding");
  b = good;
  b[46] = 2;
  expect_error(b, "layer 2");
  b = good;
  b[47] = 1;
  expect_error(b, "reserved");
  b = good;
  b[5] = 2;
  expect_error(b, "version");
  b = good;
  b[0] = 'X';
  expect_error(b, "magic");
  b = good;
  put16(b, 32, 0);  // output width 0
  expect_error(b, "output size");
  // A JPEG whose size disagrees with the rectangle.
  lf::Fragment g = f;
  auto jb = lf::serialize_fragment(g, lf::Encoding::kJpeg);
  put16(jb, 40, static_cast<uint16_t>(f.rect.width - 1));
  for (auto& s : g.spans) s[1] = std::min<uint16_t>(s[1], f.rect.x + f.rect.width - 1);
  // rewrite spans in the payload to stay inside the narrower rectangle
  for (int r = 0; r < f.rect.height; ++r) {
    put16(jb, 56 + 4 * r,
          static_cast<uint16_t>(std::min<int>(g.spans[r][0], g.spans[r][1]) - f.rect.x));
    put16(jb, 58 + 4 * r, static_cast<uint16_t>(g.spans[r][1] - f.rect.x));
  }
  expect_error(jb, "JPEG is");
  // Garbage JPEG body.
  auto gb = lf::serialize_fragment(f, lf::Encoding::kJpeg);
  for (size_t i = 56 + 4 * f.rect.height; i < gb.size(); ++i) gb[i] = 0x11;
  expect_error(gb, "JPEG");
}

// A probe's steps in one buffer each way (lib/lf/wire/probe_bundle.h): the
// requests come back as they went; anything but distinct steps of one probe
// and viewer is refused, and so is a size that is not whole requests.
// Partial sums (version 2): cameras and weight shift survive the wire, the
// spans are deflated and come back exactly, raw and JPEG; bad version-2
// headers and spans that do not inflate to their rows are refused.
TEST(Wire, PartialSumsRoundTripWithDeflatedSpans) {
  lf::Fragment f = sample_fragment();
  f.cameras = 16;
  f.weight_shift = 2;
  for (const lf::Encoding enc : {lf::Encoding::kRaw, lf::Encoding::kJpeg}) {
    const auto b = lf::serialize_fragment(f, enc);
    ASSERT_GT(b.size(), lf::kSumFragmentHeaderSize);
    EXPECT_EQ(b[5], 2);   // version 2
    EXPECT_EQ(b[55], 1);  // spans deflated
    const lf::FragmentHeader h = lf::peek_fragment_header(b.data(), b.size());
    EXPECT_EQ(h.header_size, lf::kSumFragmentHeaderSize);
    EXPECT_EQ(h.size(), b.size());
    EXPECT_EQ(h.cameras, 16);
    const lf::Fragment g = lf::parse_fragment(b.data(), b.size());
    EXPECT_EQ(g.cameras, 16);
    EXPECT_EQ(g.weight_shift, 2);
    EXPECT_EQ(g.rect, f.rect);
    EXPECT_EQ(g.spans, f.spans);
    if (enc == lf::Encoding::kRaw) {
      EXPECT_EQ(g.pixels, f.pixels);
      // 4 bytes a row of plain spans, against the deflated ones.
      lf::Fragment one = f;
      one.cameras = 1, one.weight_shift = 0;
      const auto plain = lf::serialize_fragment(one, enc);
      EXPECT_LT(b.size() - lf::kSumFragmentHeaderSize + 2 * f.spans.size(),
                plain.size() - lf::kFragmentHeaderSize)
          << "deflated spans take less than half of the plain ones";
    }
  }
  // In place: the same, pixels pointing into the buffer.
  const auto b = lf::serialize_fragment(f, lf::Encoding::kRaw);
  const uint8_t* px = nullptr;
  const lf::Fragment g = lf::parse_fragment_in_place(b.data(), b.size(), &px);
  ASSERT_NE(px, nullptr);
  EXPECT_EQ(std::memcmp(px, f.pixels.data(), f.pixels.size()), 0);
  // Hostile version-2 headers and spans (CRC rewritten: the checks must
  // catch them).
  auto reseal = [](std::vector<uint8_t> c) {
    uLong s = crc32(0L, Z_NULL, 0);
    s = crc32(s, c.data(), 56);
    s = crc32(s, c.data() + 60, static_cast<uInt>(c.size() - 60));
    for (int i = 0; i < 4; ++i) c[56 + i] = static_cast<uint8_t>(s >> (24 - 8 * i));
    return c;
  };
  auto expect_error = [&](std::vector<uint8_t> c, const std::string& word) {
    c = reseal(c);
    expect_wire_error([&] { lf::parse_fragment(c.data(), c.size()); }, word);
  };
  EXPECT_NO_THROW(lf::parse_fragment(reseal(b).data(), b.size()));
  auto c = b;
  put16(c, 52, 0);
  expect_error(c, "cameras");
  c = b;
  put16(c, 52, lf::kMaxSummedCameras + 1);
  expect_error(c, "cameras");
  c = b;
  c[54] = lf::kMaxWeightShift + 1;
  expect_error(c, "weight shift");
  c = b;
  c[55] = 3;
  expect_error(c, "flags");
  c = b;
  c[6] = 0, c[7] = 56;  // version 2 with version 1's header size
  expect_error(c, "header size");
  c = b;
  c[60] = c[61] = c[62] = c[63] = 0;  // no deflated spans at all (the fuzzer's find)
  expect_error(c, "inflate");
  c = b;
  c[60] = 0x7f;  // deflated size beyond the payload
  expect_error(c, "exceed the payload");
  c = b;
  c[60 + 4] ^= 0x55;  // the DEFLATE stream itself
  expect_error(c, "span");
  // Spans that inflate to more rows than the rectangle has.
  c = b;
  put16(c, 42, static_cast<uint16_t>(f.rect.height - 1));  // header: one row fewer
  expect_error(c, "inflate");
  // A single camera's fragment is still version 1, byte for byte.
  lf::Fragment one = f;
  one.cameras = 1, one.weight_shift = 0;
  const auto v1 = lf::serialize_fragment(one, lf::Encoding::kRaw);
  EXPECT_EQ(v1, lf::serialize_fragment(sample_fragment(), lf::Encoding::kRaw));
  EXPECT_EQ(v1[5], 1);
}

TEST(Wire, ProbeBundlesRoundTripAndRefuseStrangers) {
  const lf::Rig rig = lf::synthetic_grid_rig(3, 3, 0.5, 160, 120, 50);
  lf::ViewRequest view = sample_request();
  const std::vector<lf::ViewRequest> steps = lf::surface_probe_requests(rig, view, 77);
  ASSERT_EQ(steps.size(), 32u);
  const std::vector<uint8_t> b = lf::serialize_probe_bundle(steps);
  ASSERT_EQ(b.size(), 32 * lf::kRequestSize);
  std::vector<size_t> sizes;
  const std::vector<lf::ViewRequest> back = lf::parse_requests(b.data(), b.size(), &sizes);
  ASSERT_EQ(back.size(), 32u);
  EXPECT_EQ(sizes, std::vector<size_t>(32, lf::kRequestSize));
  for (size_t k = 0; k < 32; ++k) {
    EXPECT_EQ(lf::serialize_request(back[k]), lf::serialize_request(steps[k])) << k;
  }
  // One request, of either version, is one request.
  for (const lf::ViewRequest& one : {view, sample_surface_request(), steps[3]}) {
    const std::vector<uint8_t> v = lf::serialize_request(one);
    const auto got = lf::parse_requests(v.data(), v.size(), &sizes);
    ASSERT_EQ(got.size(), 1u);
    EXPECT_EQ(lf::serialize_request(got[0]), v);
    EXPECT_EQ(sizes, std::vector<size_t>{v.size()});
  }
  // A version-3 request whose size is a multiple of a version-2 one's is
  // still one request (its version says so).
  bool found = false;
  for (int tile = 8; tile <= 64 && !found; tile += 4)
    for (int planes = 1; planes <= 8 && !found; ++planes) {
      lf::ViewRequest r = sample_request();
      lf::FocalSurface& sf = r.surface;
      sf.tile = tile, sf.cols = (640 + tile - 1) / tile, sf.rows = (480 + tile - 1) / tile;
      for (int p = 0; p < planes; ++p)
        sf.planes.push_back(lf::FocalPlane::through({0, 0, 2.0 + p}, {0, 0, 1}));
      sf.plane_of.assign(static_cast<size_t>(sf.cols) * sf.rows, 0);
      for (size_t t = 0; t < sf.plane_of.size(); ++t) sf.plane_of[t] = t % planes;
      const std::vector<uint8_t> v = lf::serialize_request(r);
      if (v.size() % lf::kRequestSize != 0) continue;
      found = true;
      const auto got = lf::parse_requests(v.data(), v.size());
      ASSERT_EQ(got.size(), 1u);
      EXPECT_EQ(got[0].surface.plane_of, sf.plane_of);
    }
  EXPECT_TRUE(found) << "no version-3 request of a multiple of 152 bytes to try";

  auto refused = [](std::vector<lf::ViewRequest> rs, const std::string& word) {
    std::vector<uint8_t> v;
    for (const lf::ViewRequest& r : rs) {
      const std::vector<uint8_t> one = lf::serialize_request(r);
      v.insert(v.end(), one.begin(), one.end());
    }
    expect_wire_error([&] { lf::parse_requests(v.data(), v.size()); }, word);
    EXPECT_THROW(lf::serialize_probe_bundle(rs), std::invalid_argument);
  };
  std::vector<lf::ViewRequest> two(steps.begin(), steps.begin() + 2);
  auto edited = [&](auto edit) {
    std::vector<lf::ViewRequest> rs = two;
    edit(rs[1]);
    return rs;
  };
  refused(edited([](lf::ViewRequest& r) { r.viewer_id++; }), "probe and viewer");
  refused(edited([](lf::ViewRequest& r) { r.sequence = lf::surface_probe_sequence(78, 1); }),
          "probe and viewer");
  refused(edited([](lf::ViewRequest& r) { r.sequence = lf::focus_probe_sequence(77, 1); }),
          "probe and viewer");
  refused(edited([](lf::ViewRequest& r) { r.sequence = 5; }), "probe and viewer");
  refused({view, view}, "probe and viewer");  // frame requests are never bundled
  refused(edited([&](lf::ViewRequest& r) { r.sequence = two[0].sequence; }), "twice");
  // A step too large to keep 64 of (a camera holds its answers to the last).
  refused(edited([](lf::ViewRequest& r) { r.view.width = 321, r.view.height = 240; }), "pixels");
  EXPECT_NO_THROW(lf::serialize_probe_bundle(
      edited([](lf::ViewRequest& r) { r.view.width = 320, r.view.height = 240; })));
  // Beyond kMaxBundleSteps, or not whole requests.
  std::vector<uint8_t> many;
  for (size_t k = 0; k <= lf::kMaxBundleSteps; ++k) {
    lf::ViewRequest r = steps[0];
    r.sequence = lf::surface_probe_sequence(77, static_cast<int>(k));  // the last: step 64
    const std::vector<uint8_t> one = lf::serialize_request(r);
    many.insert(many.end(), one.begin(), one.end());
  }
  EXPECT_THROW(lf::parse_requests(many.data(), many.size()), lf::WireError);
  for (size_t cut : {size_t{1}, lf::kRequestSize / 2, lf::kRequestSize + 1}) {
    EXPECT_THROW(lf::parse_requests(b.data(), b.size() - cut), lf::WireError) << cut;
  }
  EXPECT_THROW(lf::serialize_probe_bundle({}), std::invalid_argument);
}

// A probe's answer: one camera's fragments of distinct steps of one probe,
// back to back; the spans follow the headers exactly.
TEST(Wire, ProbeAnswersSplitIntoTheirSteps) {
  lf::Fragment f = sample_fragment();
  std::vector<uint8_t> b;
  std::vector<size_t> sizes;
  for (int k = 0; k < 5; ++k) {
    f.sequence = lf::focus_probe_sequence(9, k);
    const std::vector<uint8_t> one =
        lf::serialize_fragment(f, k % 2 ? lf::Encoding::kJpeg : lf::Encoding::kRaw);
    sizes.push_back(one.size());
    b.insert(b.end(), one.begin(), one.end());
  }
  const std::vector<lf::FragmentSpan> spans = lf::split_probe_answer(b.data(), b.size());
  ASSERT_EQ(spans.size(), 5u);
  size_t at = 0;
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(spans[k].offset, at);
    EXPECT_EQ(spans[k].size, sizes[k]);
    EXPECT_EQ(spans[k].head.sequence, lf::focus_probe_sequence(9, k));
    const lf::Fragment g = lf::parse_fragment(b.data() + spans[k].offset, spans[k].size);
    EXPECT_EQ(g.sequence, spans[k].head.sequence);
    at += sizes[k];
  }
  // One more fragment of another kind each time: refused whole.
  auto with = [&](auto edit, const std::string& word) {
    lf::Fragment o = sample_fragment();
    o.sequence = lf::focus_probe_sequence(9, 7);
    edit(o);
    std::vector<uint8_t> v = b;
    const std::vector<uint8_t> one = lf::serialize_fragment(o, lf::Encoding::kRaw);
    v.insert(v.end(), one.begin(), one.end());
    expect_wire_error([&] { lf::split_probe_answer(v.data(), v.size()); }, word);
  };
  {  // control: another step of the probe is welcome
    lf::Fragment o = sample_fragment();
    o.sequence = lf::focus_probe_sequence(9, 7);
    std::vector<uint8_t> v = b;
    const std::vector<uint8_t> one = lf::serialize_fragment(o, lf::Encoding::kRaw);
    v.insert(v.end(), one.begin(), one.end());
    EXPECT_EQ(lf::split_probe_answer(v.data(), v.size()).size(), 6u);
  }
  with([](lf::Fragment& o) { o.camera_id++; }, "one probe");
  with([](lf::Fragment& o) { o.viewer_id++; }, "one probe");
  with([](lf::Fragment& o) { o.sequence = lf::focus_probe_sequence(10, 7); }, "one probe");
  with([](lf::Fragment& o) { o.sequence = lf::surface_probe_sequence(9, 7); }, "one probe");
  with([](lf::Fragment& o) { o.sequence = lf::focus_probe_sequence(9, 2); }, "one probe");
  with([](lf::Fragment& o) { o.sequence = 12; }, "one probe");
  with([](lf::Fragment& o) { o.layer = 1; }, "one probe");
  // Truncated anywhere in the last fragment, or trailing bytes.
  for (size_t cut = 1; cut < sizes.back(); cut += 997) {
    EXPECT_THROW(lf::split_probe_answer(b.data(), b.size() - cut), lf::WireError) << cut;
  }
  std::vector<uint8_t> trailing = b;
  trailing.push_back(0);
  EXPECT_THROW(lf::split_probe_answer(trailing.data(), trailing.size()), lf::WireError);
  // More fragments than a bundle holds.
  EXPECT_THROW(lf::split_fragments(b.data(), b.size(), 4), lf::WireError);
  EXPECT_EQ(lf::split_fragments(b.data(), b.size(), 5).size(), 5u);
}

TEST(Wire, InvalidRequestsAreRejected) {
  auto r = sample_request();
  auto b = lf::serialize_request(r);
  // Non-unit quaternion with a valid CRC.
  auto q = b;
  q[44] ^= 0x10;
  auto resign = [](std::vector<uint8_t>& v) {
    const uLong c = crc32(crc32(0L, Z_NULL, 0), v.data(), 148);
    for (int i = 0; i < 4; ++i) v[148 + i] = static_cast<uint8_t>(c >> (24 - 8 * i));
  };
  resign(q);
  EXPECT_THROW(lf::parse_request(q.data(), q.size()), lf::WireError);
  auto expect_request_error = [](const std::vector<uint8_t>& v, const std::string& word) {
    try {
      lf::parse_request(v.data(), v.size());
      ADD_FAILURE() << "accepted (" << word << ")";
    } catch (const lf::WireError& e) {
      EXPECT_NE(std::string(e.what()).find(word), std::string::npos) << e.what();
    }
  };
  // `b` changed by `edit`, with a valid CRC, is refused naming `word`.
  auto expect_edit_refused = [&](auto edit, const std::string& word) {
    auto v = b;
    edit(v);
    resign(v);
    expect_request_error(v, word);
  };
  // A time below -1.
  expect_edit_refused(
      [](auto& v) {
        for (int i = 140; i < 148; ++i) v[i] = 0xff;
        v[147] = 0xfe;  // -2
      },
      "negative");
  // Version 1 (no time) is refused by name.
  expect_edit_refused([](auto& v) { v[5] = 1; }, "unsupported version 1");
  // Aperture scales at or below 1 (other than 0, the tent) or over 16.
  for (const int q8 : {1, 256, 4097, 0xffff})
    expect_edit_refused(
        [q8](auto& v) {
          v[138] = static_cast<uint8_t>(q8 >> 8), v[139] = static_cast<uint8_t>(q8);
        },
        "aperture scale");
  expect_edit_refused([](auto& v) { v[137] = 2; }, "sampling");
  expect_edit_refused([](auto& v) { v[136] = 3; }, "unknown aperture");
  expect_edit_refused([](auto& v) { v[136] = 1, v[138] = 0, v[139] = 1; }, "ULR aperture");
  expect_edit_refused([](auto& v) { v[136] = 1, v[138] = 0, v[139] = 17; }, "ULR aperture");
  // Serializing an invalid request refuses.
  r.aperture_scale = 0.5;
  EXPECT_THROW(lf::serialize_request(r), std::invalid_argument);
  r.aperture_scale = 1;
  r.view.vfov_deg = 200;
  EXPECT_THROW(lf::serialize_request(r), std::invalid_argument);
  // Random garbage never crashes.
  std::mt19937_64 rng(9);
  for (int k = 0; k < 2000; ++k) {
    std::vector<uint8_t> g(rng() % 400);
    for (auto& x : g) x = static_cast<uint8_t>(rng());
    if (g.size() >= 4) std::memcpy(g.data(), k % 2 ? "LFVR" : "LFFR", 4);
    EXPECT_THROW(lf::parse_request(g.data(), g.size()), lf::WireError);
    EXPECT_THROW(lf::parse_fragment(g.data(), g.size()), lf::WireError);
  }
}

}  // namespace

namespace {
// A fragment of camera 5 for request 9, viewer 2 covering the w x h tile at
// (x, y) of a 64 x 48 frame.
std::vector<uint8_t> tile_fragment(int x, int y, int w, int h, uint8_t layer = 0,
                                   uint32_t camera = 5) {
  lf::Fragment f;
  f.viewer_id = 2, f.sequence = 9, f.camera_id = camera, f.layer = layer;
  f.out_width = 64, f.out_height = 48;
  f.rect = cv::Rect(x, y, w, h);
  for (int r = 0; r < h; ++r)
    f.spans.push_back({static_cast<uint16_t>(x), static_cast<uint16_t>(x + w)});
  f.pixels.assign(4 * static_cast<size_t>(w) * h, 128);
  return lf::serialize_fragment(f, lf::Encoding::kRaw);
}
std::vector<uint8_t> concat(std::initializer_list<std::vector<uint8_t>> parts) {
  std::vector<uint8_t> out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}
}  // namespace

// lf::parse_frame_answer: one fragment, a camera's layer pair, or its quilt
// eyes (apart from one another), nothing else; within the pixel limit.
TEST(Wire, FrameAnswersAreOneFragmentALayerPairOrQuiltEyes) {
  const size_t frame = 64 * 48;
  auto parse = [&](const std::vector<uint8_t>& b, size_t limit) {
    return lf::parse_frame_answer(b.data(), b.size(), limit);
  };
  const auto one = tile_fragment(0, 0, 64, 48);
  ASSERT_EQ(parse(one, frame).size(), 1u);
  EXPECT_EQ(parse(one, frame)[0].encoding, lf::Encoding::kRaw);
  EXPECT_EQ(parse(one, frame)[0].pixels, one.data() + (one.size() - 4 * frame));
  // A layer pair: each may cover the whole frame.
  const auto pair = concat({tile_fragment(0, 0, 64, 48, 0), tile_fragment(0, 0, 64, 48, 1)});
  const auto parts = parse(pair, frame);
  ASSERT_EQ(parts.size(), 2u);
  EXPECT_EQ(parts[1].f.layer, 1);
  // Quilt eyes: four 32 x 24 tiles, apart; together at most the frame.
  const auto quilt = concat({tile_fragment(0, 0, 32, 24), tile_fragment(32, 0, 32, 24),
                             tile_fragment(0, 24, 32, 24), tile_fragment(32, 24, 32, 24)});
  EXPECT_EQ(parse(quilt, frame).size(), 4u);
  EXPECT_THROW(parse(quilt, frame - 1), lf::WireError);
  // Refused: the same layer twice over the same pixels (a copy), an
  // overlapping eye, another camera's fragment, layer 1 first, three layers.
  EXPECT_THROW(parse(concat({one, one}), frame), lf::WireError);
  EXPECT_THROW(parse(concat({tile_fragment(0, 0, 32, 24), tile_fragment(16, 0, 32, 24)}), frame),
               lf::WireError);
  EXPECT_THROW(
      parse(concat({tile_fragment(0, 0, 32, 24), tile_fragment(32, 0, 32, 24, 0, 6)}), frame),
      lf::WireError);
  EXPECT_THROW(
      parse(concat({tile_fragment(0, 0, 64, 48, 1), tile_fragment(0, 0, 64, 48, 0)}), frame),
      lf::WireError);
  EXPECT_THROW(parse(concat({pair, tile_fragment(0, 0, 8, 8, 1)}), frame), lf::WireError);
  // A truncated buffer.
  EXPECT_THROW(parse(std::vector<uint8_t>(quilt.begin(), quilt.end() - 1), frame), lf::WireError);
}

// RTP sequence and timestamp checks of plain RTP (lf/wire/rtp_guard.h): a
// stream of 90 kHz packets (bursts of 4 every 10 ms, the sender's clock
// starting at a random offset), with packets forged under its SSRC.
namespace {
struct RtpStream {
  uint16_t seq = 61000;  // wraps within the test
  uint32_t ts0 = 0xfffe0000u;
  int64_t t_us = 1000000;
  int n = 0;
  // The next packet, 10 ms after the last burst began every 4th packet.
  std::pair<uint16_t, uint32_t> next() {
    if (n % 4 == 0 && n) t_us += 10000;
    ++n;
    return {seq++, ts0 + static_cast<uint32_t>(t_us * 9 / 100)};
  }
};
}  // namespace

TEST(RtpGuard, ForgedPacketsWithTheSsrcNeitherPassNorMoveTheWindow) {
  using V = lf::RtpSequenceGuard::Verdict;
  lf::RtpSequenceGuard guard(90000);
  RtpStream s;
  std::mt19937 rng(7);
  int real_dropped = 0, forged_passed = 0, forged = 0;
  // Jumps as the issue lists them: +4000, +3 and +1..+10 ahead of the
  // stream, with an unknown (random) timestamp, and with the stream's own
  // (an attacker who saw one packet) for the jump, in runs of two in
  // sequence as a packetiser sends them.
  const int jumps[] = {4000, 3, 1, 2, 4, 5, 6, 7, 8, 9, 10};
  for (int i = 0; i < 4000; ++i) {
    const auto [seq, ts] = s.next();
    const V v = guard.check(seq, ts, s.t_us);
    if (i == 0) {
      EXPECT_EQ(v, V::probation);  // RFC 3550 A.1: a new source's first packet
    } else if (v != V::accept) {
      ++real_dropped;
    }
    if (i >= 20 && i % 5 == 2) {  // once the window is established
      const int jump = jumps[(i / 5) % 11];
      const bool known_ts = jump == 4000;
      for (int k = 0; k < 2; ++k) {
        const uint16_t fseq = static_cast<uint16_t>(seq + jump + k);
        const uint32_t fts = known_ts ? ts : static_cast<uint32_t>(rng());
        ++forged;
        if (guard.check(fseq, fts, s.t_us) == V::accept) ++forged_passed;
      }
    }
  }
  EXPECT_EQ(real_dropped, 0);
  // A random timestamp lands in the plausible range (2 s and the 10 ms
  // since the last packet, at 90 kHz) about once in 23,600: 0.06 expected
  // of the 1,450 in the window, 2 or more with probability 0.002.
  EXPECT_LE(forged_passed, 1) << "of " << forged;
  EXPECT_EQ(guard.restarts(), 0);
}

TEST(RtpGuard, LossReorderingAndARestartedSenderAreTheStreams) {
  using V = lf::RtpSequenceGuard::Verdict;
  lf::RtpSequenceGuard guard(90000);
  RtpStream s;
  std::mt19937 rng(3);
  int dropped = 0, sent = 0;
  uint16_t held_seq = 0;
  uint32_t held_ts = 0;
  bool holding = false;
  for (int i = 0; i < 3000; ++i) {
    const auto [seq, ts] = s.next();
    if (i > 1 && rng() % 20 == 0) continue;      // 5 % lost
    if (i > 1 && !holding && rng() % 25 == 0) {  // arrives after the next one
      held_seq = seq, held_ts = ts, holding = true;
      continue;
    }
    ++sent;
    if (guard.check(seq, ts, s.t_us) != V::accept && i > 0) ++dropped;
    if (holding && (++sent, guard.check(held_seq, held_ts, s.t_us) != V::accept)) ++dropped;
    holding = false;
  }
  EXPECT_EQ(dropped, 0) << "of " << sent;
  // The sender restarts: a new random sequence number and clock offset,
  // 300 ms after its last packet. Its packets are a jump until they
  // outnumber the old sequence's (counts decaying over 1 s): here after
  // about 0.45 s; from then on each is the stream's.
  RtpStream r;
  r.seq = 30000;
  r.ts0 = 123456789u;
  r.t_us = s.t_us + 300000;
  const int64_t restart_us = r.t_us;
  int64_t taken_us = -1;
  int after = 0, accepted_after = 0;
  for (int i = 0; i < 1200; ++i) {
    const auto [seq, ts] = r.next();
    const V v = guard.check(seq, ts, r.t_us);
    if (taken_us < 0 && v == V::accept) taken_us = r.t_us;
    if (taken_us >= 0) ++after, accepted_after += v == V::accept;
  }
  EXPECT_EQ(guard.restarts(), 1);
  EXPECT_GT(taken_us - restart_us, 200000);
  EXPECT_LT(taken_us - restart_us, 1000000);
  EXPECT_EQ(accepted_after, after);
}

TEST(RtpGuard, AWindowTakenByForgedPacketsFirstIsTakenBack) {
  using V = lf::RtpSequenceGuard::Verdict;
  lf::RtpSequenceGuard guard(90000);
  // Two forged packets in sequence before the stream's first: the window is
  // theirs until the stream's packets outnumber them (its third).
  EXPECT_EQ(guard.check(30000, 5, 0), V::probation);
  EXPECT_EQ(guard.check(30001, 5, 10), V::accept);
  RtpStream s;
  s.t_us = 20;
  int accepted = 0;
  for (int i = 0; i < 50; ++i) {
    const auto [seq, ts] = s.next();
    if (guard.check(seq, ts, s.t_us) == V::accept) ++accepted;
  }
  EXPECT_GE(accepted, 47);  // from the one after which the stream outnumbers them
  EXPECT_EQ(guard.restarts(), 1);
  // And the forged run cannot come back while the stream flows.
  EXPECT_EQ(guard.check(30002, 5, s.t_us), V::jump);
  EXPECT_EQ(guard.check(30003, 5, s.t_us), V::jump);
}

TEST(RtpGuard, AStreamInsideAForgedWindowIsStillFollowed) {
  using V = lf::RtpSequenceGuard::Verdict;
  lf::RtpSequenceGuard guard(90000);
  // A forged pair takes the window before the stream starts, with sequence
  // numbers just below the stream's: the stream's packets fall in that
  // window, but not its timestamps. They are followed all the same, and
  // the stream's second packet outnumbers the pair (whose count decayed).
  RtpStream s;
  EXPECT_EQ(guard.check(s.seq - 10, 5, 0), V::probation);
  EXPECT_EQ(guard.check(s.seq - 9, 5, 10), V::accept);
  s.t_us = 20;
  int accepted = 0;
  for (int i = 0; i < 50; ++i) {
    const auto [seq, ts] = s.next();
    const V v = guard.check(seq, ts, s.t_us);
    if (i == 0) {
      EXPECT_EQ(v, V::timestamp);
    }
    accepted += v == V::accept;
  }
  EXPECT_EQ(accepted, 49);
}
