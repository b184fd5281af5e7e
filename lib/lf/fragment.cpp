#include "lf/fragment.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#if defined(__SSE2__) && !defined(LF_NO_SIMD)
#include <emmintrin.h>
#define LF_SSE2 1
#endif

namespace lf {

namespace {

constexpr int kBlock = 64;
constexpr int kWeightBits = 14;  // bilinear weights in 1/16384

// Per-run constants in float.
struct RunCoeffs {
  float xa, xb, ya, yb, za, zb;  // homography rows: a * x + b (b includes y)
  float na, nb, da, db;          // weight = (na x + nb) / (da x + db)
};

struct SamplerLimits {
  float umax, vmax;      // last valid coordinate (size - 0.5)
  float uclamp, vclamp;  // clamp so that floor() <= size - 2
  int stride;
  // distortion
  bool distort;
  float fx, fy, cx, cy, ifx, ify, k1, k2, r2max;
};

// Pass 1: sampling coordinates and packed fixed-point bilinear weights with
// the aperture weight folded in. Written to be auto-vectorised.
void coords(const RunCoeffs& c, const SamplerLimits& L, int x0, int n, int32_t* off, int32_t* wtop,
            int32_t* wbot) {
  for (int i = 0; i < n; ++i) {
    const float x = static_cast<float>(x0 + i);
    const float X = c.xa * x + c.xb;
    const float Y = c.ya * x + c.yb;
    const float Z = c.za * x + c.zb;
    const float iz = 1.0f / Z;
    float u = X * iz, v = Y * iz;
    bool ok = Z > 0.0f;
    if (L.distort) {
      const float xn = (u - L.cx) * L.ifx, yn = (v - L.cy) * L.ify;
      const float r2 = xn * xn + yn * yn;
      const float f = 1.0f + r2 * (L.k1 + L.k2 * r2);
      ok = ok && r2 <= L.r2max;
      u = L.fx * xn * f + L.cx;
      v = L.fy * yn * f + L.cy;
    }
    float w = (c.na * x + c.nb) / (c.da * x + c.db);
    w = w > 1.0f ? 1.0f : w;
    ok = ok && (w > 0.0f) && (u >= -0.5f) && (u <= L.umax) && (v >= -0.5f) && (v <= L.vmax);
    u = ok ? u : 0.0f;
    v = ok ? v : 0.0f;
    w = ok ? w : 0.0f;
    u = u < 0.0f ? 0.0f : (u > L.uclamp ? L.uclamp : u);
    v = v < 0.0f ? 0.0f : (v > L.vclamp ? L.vclamp : v);
    const int iu = static_cast<int>(u), iv = static_cast<int>(v);
    const float fu = u - static_cast<float>(iu), fv = v - static_cast<float>(iv);
    const float wq = w * static_cast<float>(1 << kWeightBits);
    const float top = (1.0f - fv) * wq, bot = fv * wq;
    const int w00 = static_cast<int>((1.0f - fu) * top + 0.5f);
    const int w01 = static_cast<int>(fu * top + 0.5f);
    const int w10 = static_cast<int>((1.0f - fu) * bot + 0.5f);
    const int w11 = static_cast<int>(fu * bot + 0.5f);
    off[i] = iv * L.stride + iu * 4;
    wtop[i] = w00 | (w01 << 16);
    wbot[i] = w10 | (w11 << 16);
  }
}

// Pass 2: gather four RGBA taps per pixel and blend in fixed point.
void gather(const uint8_t* src, int stride, int n, const int32_t* off, const int32_t* wtop,
            const int32_t* wbot, uint8_t* dst) {
#ifdef LF_SSE2
  const __m128i zero = _mm_setzero_si128();
  const __m128i round = _mm_set1_epi32(1 << (kWeightBits - 1));
  for (int i = 0; i < n; ++i) {
    const uint8_t* p = src + off[i];
    __m128i t = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p));
    __m128i b = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p + stride));
    t = _mm_unpacklo_epi8(_mm_unpacklo_epi8(t, _mm_srli_si128(t, 4)), zero);
    b = _mm_unpacklo_epi8(_mm_unpacklo_epi8(b, _mm_srli_si128(b, 4)), zero);
    __m128i acc = _mm_add_epi32(_mm_madd_epi16(t, _mm_set1_epi32(wtop[i])),
                                _mm_madd_epi16(b, _mm_set1_epi32(wbot[i])));
    acc = _mm_srli_epi32(_mm_add_epi32(acc, round), kWeightBits);
    acc = _mm_packs_epi32(acc, acc);
    acc = _mm_packus_epi16(acc, acc);
    const int32_t px = _mm_cvtsi128_si32(acc);
    std::memcpy(dst + 4 * i, &px, 4);
  }
#else
  for (int i = 0; i < n; ++i) {
    const uint8_t* p = src + off[i];
    const int w00 = wtop[i] & 0xffff, w01 = (wtop[i] >> 16) & 0xffff;
    const int w10 = wbot[i] & 0xffff, w11 = (wbot[i] >> 16) & 0xffff;
    for (int ch = 0; ch < 4; ++ch) {
      const int acc = p[ch] * w00 + p[4 + ch] * w01 + p[stride + ch] * w10 +
                      p[stride + 4 + ch] * w11 + (1 << (kWeightBits - 1));
      dst[4 * i + ch] = static_cast<uint8_t>(std::min(255, acc >> kWeightBits));
    }
  }
#endif
}

}  // namespace

void render_fragment(const FragmentPlan& plan, const Camera& cam, const cv::Mat& image,
                     Fragment& out) {
  if (image.type() != CV_8UC4)
    throw std::invalid_argument("render_fragment: camera " + std::to_string(cam.id) +
                                ": image must be 8-bit 4-channel (CV_8UC4)");
  if (image.cols != cam.width || image.rows != cam.height)
    throw std::invalid_argument("render_fragment: camera " + std::to_string(cam.id) + ": image " +
                                std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                " does not match the rig's " + std::to_string(cam.width) + "x" +
                                std::to_string(cam.height));
  out.camera_id = static_cast<uint32_t>(cam.id);
  out.out_width = plan.out_width;
  out.out_height = plan.out_height;
  out.rect = plan.rect;
  out.spans.resize(plan.row_spans.size());
  std::vector<size_t> row_offset(plan.row_spans.size() + 1, 0);
  for (size_t r = 0; r < plan.row_spans.size(); ++r) {
    out.spans[r] = {static_cast<uint16_t>(plan.row_spans[r][0]),
                    static_cast<uint16_t>(plan.row_spans[r][1])};
    row_offset[r + 1] = row_offset[r] + 4 * (plan.row_spans[r][1] - plan.row_spans[r][0]);
  }
  out.pixels.assign(row_offset.back(), 0);
  if (plan.runs.empty()) return;

  SamplerLimits L;
  L.umax = static_cast<float>(cam.width) - 0.5f;
  L.vmax = static_cast<float>(cam.height) - 0.5f;
  L.uclamp = static_cast<float>(cam.width - 1) - 1.0f / 1024.0f;
  L.vclamp = static_cast<float>(cam.height - 1) - 1.0f / 1024.0f;
  L.stride = static_cast<int>(image.step[0]);
  const Intrinsics& K = cam.intrinsics;
  L.distort = K.has_distortion();
  L.fx = static_cast<float>(K.fx), L.fy = static_cast<float>(K.fy);
  L.cx = static_cast<float>(K.cx), L.cy = static_cast<float>(K.cy);
  L.ifx = static_cast<float>(1.0 / K.fx), L.ify = static_cast<float>(1.0 / K.fy);
  L.k1 = static_cast<float>(K.k1), L.k2 = static_cast<float>(K.k2);
  const double rf = distortion_fold_radius(K);
  L.r2max = std::isfinite(rf) ? static_cast<float>(rf * rf) : INFINITY;

  alignas(16) int32_t off[kBlock], wtop[kBlock], wbot[kBlock];
  for (const Run& run : plan.runs) {
    const FragmentPiece& pc = plan.pieces[run.piece];
    const double y = run.y;
    const cv::Matx33d& H = pc.H;
    RunCoeffs c;
    c.xa = static_cast<float>(H(0, 0)), c.xb = static_cast<float>(H(0, 1) * y + H(0, 2));
    c.ya = static_cast<float>(H(1, 0)), c.yb = static_cast<float>(H(1, 1) * y + H(1, 2));
    c.za = static_cast<float>(H(2, 0)), c.zb = static_cast<float>(H(2, 1) * y + H(2, 2));
    c.na = static_cast<float>(pc.weight_num.a);
    c.nb = static_cast<float>(pc.weight_num.b * y + pc.weight_num.c);
    c.da = static_cast<float>(pc.weight_den.a);
    c.db = static_cast<float>(pc.weight_den.b * y + pc.weight_den.c);
    const int r = run.y - plan.rect.y;
    uint8_t* row = out.pixels.data() + row_offset[r];
    for (int x = run.x0; x < run.x1; x += kBlock) {
      const int n = std::min(kBlock, run.x1 - x);
      coords(c, L, x, n, off, wtop, wbot);
      gather(image.data, L.stride, n, off, wtop, wbot, row + 4 * (x - plan.row_spans[r][0]));
    }
  }
}

void check_fragment(const Fragment& f) {
  auto bad = [&](const std::string& what) {
    throw std::invalid_argument("fragment from camera " + std::to_string(f.camera_id) + ": " +
                                what);
  };
  if (f.out_width < 1 || f.out_height < 1 || f.out_width > 16384 || f.out_height > 16384)
    bad("output size out of range");
  if (f.empty()) {
    if (!f.spans.empty() || !f.pixels.empty()) bad("empty fragment carries data");
    return;
  }
  const cv::Rect& r = f.rect;
  if (r.x < 0 || r.y < 0 || r.width <= 0 || r.height <= 0 || r.x + r.width > f.out_width ||
      r.y + r.height > f.out_height)
    bad("rectangle lies outside the " + std::to_string(f.out_width) + "x" +
        std::to_string(f.out_height) + " output");
  if (f.spans.size() != static_cast<size_t>(r.height))
    bad("has " + std::to_string(f.spans.size()) + " row spans for " + std::to_string(r.height) +
        " rows");
  size_t n = 0;
  for (const auto& s : f.spans) {
    if (s[0] > s[1] || s[0] < r.x || s[1] > r.x + r.width) bad("row span outside its rectangle");
    n += s[1] - s[0];
  }
  if (f.pixels.size() != 4 * n)
    bad("pixel data is " + std::to_string(f.pixels.size()) + " bytes, spans need " +
        std::to_string(4 * n));
}

void Compositor::reset(int width, int height) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw std::invalid_argument("compositor: output size out of range");
  w_ = width;
  h_ = height;
  acc_.assign(static_cast<size_t>(width) * height * 4, 0);
}

void Compositor::add(const Fragment& f) {
  if (f.out_width != w_ || f.out_height != h_)
    throw std::invalid_argument("compositor: fragment from camera " + std::to_string(f.camera_id) +
                                " is for a " + std::to_string(f.out_width) + "x" +
                                std::to_string(f.out_height) + " frame, not " + std::to_string(w_) +
                                "x" + std::to_string(h_));
  check_fragment(f);
  const uint8_t* px = f.pixels.data();
  for (int r = 0; r < f.rect.height; ++r) {
    const int b = f.spans[r][0], e = f.spans[r][1];
    uint32_t* acc = acc_.data() + (static_cast<size_t>(f.rect.y + r) * w_ + b) * 4;
    const int n = 4 * (e - b);
    for (int i = 0; i < n; ++i) acc[i] += px[i];
    px += n;
  }
}

void Compositor::resolve(cv::Mat& out) const {
  out.create(h_, w_, CV_8UC4);
  for (int y = 0; y < h_; ++y) {
    const uint32_t* a = acc_.data() + static_cast<size_t>(y) * w_ * 4;
    uint8_t* o = out.ptr<uint8_t>(y);
    for (int x = 0; x < w_; ++x, a += 4, o += 4) {
      if (a[3] == 0) {
        o[0] = o[1] = o[2] = o[3] = 0;
        continue;
      }
      const float s = 255.0f / static_cast<float>(a[3]);
      for (int ch = 0; ch < 3; ++ch)
        o[ch] = static_cast<uint8_t>(std::min(255.0f, static_cast<float>(a[ch]) * s + 0.5f));
      o[3] = 255;
    }
  }
}

}  // namespace lf
