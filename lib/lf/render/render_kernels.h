// Internal to lib/lf/render*.cpp (not installed): the fragment kernel's
// per-run constants, the scalar reference of its coordinate pass, and the
// vector kernels that must reproduce it bit for bit.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>

#if (defined(__x86_64__) || defined(_M_X64)) && !defined(LF_NO_SIMD)
#define LF_X86_SIMD 1  // SSE2 always (x86-64 baseline); AVX2 chosen at run time
#endif

namespace lf::kernels {

constexpr int kBlock = 64;       // pixels per coordinate/gather block
constexpr int kWeightBits = 14;  // bilinear weights in 1/16384

// Bicubic sampling (Keys 1981, a = -0.5, Catmull-Rom): the coordinate pass
// gives the sub-pixel phases in 1/256 and the aperture weight in 1/16384;
// the gather takes each phase's four tap weights (1/4096, summing to 4096
// exactly) from one table, so every kernel computes the same integers.
constexpr int kPhaseBits = 8;
constexpr int kCubicBits = 12;
using CubicTaps = int16_t[4];
// 2^kPhaseBits + 1 entries: phase 0 .. 256 (1.0, the next pixel).
const CubicTaps* cubic_taps();

// One run's constants: the homography's rows as affine functions of x
// (X = xa x + xb, ...), the aperture weight's numerator and denominator, the
// camera's sampling limits and its radial distortion (lf/geometry/camera.h).
struct Consts {
  float xa, xb, ya, yb, za, zb, na, nb, da, db;
  float umax, vmax, uclamp, vclamp;
  float fx, fy, cx, cy, ifx, ify, k1, k2, r2max;
};

// Pass 1 for one pixel: integer tap position (iu, iv) and the packed
// fixed-point bilinear weights with the aperture weight folded in
// (w00 | w01 << 16, w10 | w11 << 16). The reference for every vector kernel:
// they evaluate the same expressions in the same order (min/max operand
// order included, so NaNs behave alike, and no fused multiply-add).
// With kCubic: wt = phase_u | phase_v << 16 (in 1/256, 0..256), wb = the
// aperture weight in 1/16384, for gather_cubic1.
template <bool kDistort, bool kCubic = false>
inline void coord1(const Consts& k, float x, int32_t& iu_out, int32_t& iv_out, int32_t& wt,
                   int32_t& wb) {
  const float X = k.xa * x + k.xb, Y = k.ya * x + k.yb, Z = k.za * x + k.zb;
  const float iz = 1.0f / Z;
  float u = X * iz, v = Y * iz;
  bool ok = Z > 0.0f;
  if constexpr (kDistort) {
    const float xn = (u - k.cx) * k.ifx, yn = (v - k.cy) * k.ify;
    const float r2 = xn * xn + yn * yn;
    const float f = 1.0f + r2 * (k.k1 + k.k2 * r2);
    ok = ok & (r2 <= k.r2max);
    u = k.fx * (xn * f) + k.cx;
    v = k.fy * (yn * f) + k.cy;
  }
  float w = (k.na * x + k.nb) / (k.da * x + k.db);
  w = 1.0f < w ? 1.0f : w;
  ok = ok & (w > 0.0f) & (u >= -0.5f) & (u <= k.umax) & (v >= -0.5f) & (v <= k.vmax);
  if (!ok) u = v = w = 0.0f;
  u = 0.0f > u ? 0.0f : u;
  v = 0.0f > v ? 0.0f : v;
  u = k.uclamp < u ? k.uclamp : u;
  v = k.vclamp < v ? k.vclamp : v;
  const int iu = static_cast<int>(u), iv = static_cast<int>(v);
  const float fu = u - static_cast<float>(iu), fv = v - static_cast<float>(iv);
  const float wq = w * static_cast<float>(1 << kWeightBits);
  iu_out = iu;
  iv_out = iv;
  if constexpr (kCubic) {
    const float phases = static_cast<float>(1 << kPhaseBits);
    wt = static_cast<int>(fu * phases + 0.5f) | (static_cast<int>(fv * phases + 0.5f) << 16);
    wb = static_cast<int>(wq + 0.5f);
    return;
  }
  const float top = (1.0f - fv) * wq, bot = fv * wq;
  const int w00 = static_cast<int>((1.0f - fu) * top + 0.5f);
  const int w01 = static_cast<int>(fu * top + 0.5f);
  const int w10 = static_cast<int>((1.0f - fu) * bot + 0.5f);
  const int w11 = static_cast<int>(fu * bot + 0.5f);
  wt = w00 | (w01 << 16);
  wb = w10 | (w11 << 16);
}

// Pass 2 for one pixel: the four taps blended in fixed point (reference).
inline void gather1(const uint8_t* src, int stride, int32_t iu, int32_t iv, int32_t wtop,
                    int32_t wbot, uint8_t* dst) {
  const uint8_t* p = src + static_cast<std::ptrdiff_t>(iv) * stride + 4 * iu;
  const int w00 = wtop & 0xffff, w01 = (wtop >> 16) & 0xffff;
  const int w10 = wbot & 0xffff, w11 = (wbot >> 16) & 0xffff;
  for (int ch = 0; ch < 4; ++ch) {
    const int acc = p[ch] * w00 + p[4 + ch] * w01 + p[stride + ch] * w10 +
                    p[stride + 4 + ch] * w11 + (1 << (kWeightBits - 1));
    dst[ch] = static_cast<uint8_t>(acc >> kWeightBits < 255 ? acc >> kWeightBits : 255);
  }
}

// Bicubic pass 2 for one pixel (reference): the 4 x 4 taps around
// (iu, iv), clamped to the width x height image, rows filtered first
// (rounded to whole levels, as the vector kernel does), then columns; the
// value clamped to 0..255 and scaled by the aperture weight wq (1/16384),
// so colour never exceeds alpha (premultiplied).
inline void gather_cubic1(const uint8_t* src, int stride, int width, int height, int32_t iu,
                          int32_t iv, int32_t phases, int32_t wq, uint8_t* dst) {
  const int16_t* h = cubic_taps()[phases & 0xffff];
  const int16_t* v = cubic_taps()[(phases >> 16) & 0xffff];
  int col[4];
  for (int i = 0; i < 4; ++i) col[i] = 4 * std::clamp(iu - 1 + i, 0, width - 1);
  int acc[4] = {0, 0, 0, 0};
  for (int j = 0; j < 4; ++j) {
    const uint8_t* row =
        src + static_cast<std::ptrdiff_t>(std::clamp(iv - 1 + j, 0, height - 1)) * stride;
    for (int ch = 0; ch < 4; ++ch) {
      const int r = row[col[0] + ch] * h[0] + row[col[1] + ch] * h[1] + row[col[2] + ch] * h[2] +
                    row[col[3] + ch] * h[3] + (1 << (kCubicBits - 1));
      acc[ch] += (r >> kCubicBits) * v[j];
    }
  }
  for (int ch = 0; ch < 4; ++ch) {
    const int val = std::clamp((acc[ch] + (1 << (kCubicBits - 1))) >> kCubicBits, 0, 255);
    dst[ch] = static_cast<uint8_t>((val * wq + (1 << (kWeightBits - 1))) >> kWeightBits);
  }
}

#ifdef LF_X86_SIMD
// AVX2 kernels (render_avx2.cpp): call only where the CPU has AVX2.
void coords_avx2(bool distort, bool cubic, const Consts& k, int x0, int n, int32_t* iu, int32_t* iv,
                 int32_t* wt, int32_t* wb, int stride, int32_t* off);
void gather_cubic_avx2(const uint8_t* src, int stride, int width, int height, int n,
                       const int32_t* iu, const int32_t* iv, const int32_t* phases,
                       const int32_t* wq, uint8_t* dst);
void gather_avx2(const uint8_t* src, int stride, int n, const int32_t* off, const int32_t* iu,
                 const int32_t* iv, const int32_t* wtop, const int32_t* wbot, uint8_t* dst);
// AVX-512 coordinate pass and bilinear gather (render_avx512.cpp): call only
// where the CPU has AVX-512 F, DQ, BW and VL (and so AVX2: their tails and
// the bicubic gather are AVX2's).
void coords_avx512(bool distort, bool cubic, const Consts& k, int x0, int n, int32_t* iu,
                   int32_t* iv, int32_t* wt, int32_t* wb, int stride, int32_t* off);
// `hardware`: the taps read by the AVX-512 gather instruction, else by
// scalar loads (lf/render/render.h TapLoads); the same bytes either way.
void gather_avx512(bool hardware, const uint8_t* src, int stride, int n, const int32_t* off,
                   const int32_t* iu, const int32_t* iv, const int32_t* wtop, const int32_t* wbot,
                   uint8_t* dst);
#endif

}  // namespace lf::kernels
