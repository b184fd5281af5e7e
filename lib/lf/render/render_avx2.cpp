// AVX2 versions of the fragment kernel's two passes (lf/render/render_kernels.h):
// eight pixels per step in the coordinate pass, four in the gather. Compiled
// for AVX2 by function attribute and called only after a run-time check
// (render.cpp), so the library still runs on any x86-64. No FMA: every
// product is rounded as in the scalar reference, so the output is
// bit-identical (tests/test_render.cpp).
#include "lf/render/render_kernels.h"

#ifdef LF_X86_SIMD
#include <immintrin.h>

#include <cstring>

#define LF_AVX2 __attribute__((target("avx2")))

namespace lf::kernels {

namespace {

template <bool kDistort, bool kCubic>
LF_AVX2 void coords8(const Consts& k, int x0, int n, int32_t* iu, int32_t* iv, int32_t* wt,
                     int32_t* wb, int stride, int32_t* off) {
  const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
  const __m256 half = _mm256_set1_ps(0.5f), mhalf = _mm256_set1_ps(-0.5f);
  const __m256 scale = _mm256_set1_ps(static_cast<float>(1 << kWeightBits));
  const __m256 xa = _mm256_set1_ps(k.xa), xb = _mm256_set1_ps(k.xb);
  const __m256 ya = _mm256_set1_ps(k.ya), yb = _mm256_set1_ps(k.yb);
  const __m256 za = _mm256_set1_ps(k.za), zb = _mm256_set1_ps(k.zb);
  const __m256 na = _mm256_set1_ps(k.na), nb = _mm256_set1_ps(k.nb);
  const __m256 da = _mm256_set1_ps(k.da), db = _mm256_set1_ps(k.db);
  const __m256 umax = _mm256_set1_ps(k.umax), vmax = _mm256_set1_ps(k.vmax);
  const __m256 uclamp = _mm256_set1_ps(k.uclamp), vclamp = _mm256_set1_ps(k.vclamp);
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(x0 + i), lane));
    const __m256 X = _mm256_add_ps(_mm256_mul_ps(xa, x), xb);
    const __m256 Y = _mm256_add_ps(_mm256_mul_ps(ya, x), yb);
    const __m256 Z = _mm256_add_ps(_mm256_mul_ps(za, x), zb);
    const __m256 iz = _mm256_div_ps(one, Z);
    __m256 u = _mm256_mul_ps(X, iz), v = _mm256_mul_ps(Y, iz);
    __m256 ok = _mm256_cmp_ps(Z, zero, _CMP_GT_OQ);
    if constexpr (kDistort) {
      const __m256 cx = _mm256_set1_ps(k.cx), cy = _mm256_set1_ps(k.cy);
      const __m256 xn = _mm256_mul_ps(_mm256_sub_ps(u, cx), _mm256_set1_ps(k.ifx));
      const __m256 yn = _mm256_mul_ps(_mm256_sub_ps(v, cy), _mm256_set1_ps(k.ify));
      const __m256 r2 = _mm256_add_ps(_mm256_mul_ps(xn, xn), _mm256_mul_ps(yn, yn));
      const __m256 f = _mm256_add_ps(
          one, _mm256_mul_ps(r2, _mm256_add_ps(_mm256_set1_ps(k.k1),
                                               _mm256_mul_ps(_mm256_set1_ps(k.k2), r2))));
      ok = _mm256_and_ps(ok, _mm256_cmp_ps(r2, _mm256_set1_ps(k.r2max), _CMP_LE_OQ));
      u = _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(k.fx), _mm256_mul_ps(xn, f)), cx);
      v = _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(k.fy), _mm256_mul_ps(yn, f)), cy);
    }
    __m256 w = _mm256_div_ps(_mm256_add_ps(_mm256_mul_ps(na, x), nb),
                             _mm256_add_ps(_mm256_mul_ps(da, x), db));
    w = _mm256_min_ps(one, w);
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(w, zero, _CMP_GT_OQ));
    ok = _mm256_and_ps(
        ok, _mm256_and_ps(_mm256_cmp_ps(u, mhalf, _CMP_GE_OQ), _mm256_cmp_ps(u, umax, _CMP_LE_OQ)));
    ok = _mm256_and_ps(
        ok, _mm256_and_ps(_mm256_cmp_ps(v, mhalf, _CMP_GE_OQ), _mm256_cmp_ps(v, vmax, _CMP_LE_OQ)));
    u = _mm256_and_ps(ok, u);
    v = _mm256_and_ps(ok, v);
    w = _mm256_and_ps(ok, w);
    u = _mm256_min_ps(uclamp, _mm256_max_ps(zero, u));
    v = _mm256_min_ps(vclamp, _mm256_max_ps(zero, v));
    const __m256i iuv = _mm256_cvttps_epi32(u), ivv = _mm256_cvttps_epi32(v);
    const __m256 fu = _mm256_sub_ps(u, _mm256_cvtepi32_ps(iuv));
    const __m256 fv = _mm256_sub_ps(v, _mm256_cvtepi32_ps(ivv));
    const __m256 wq = _mm256_mul_ps(w, scale);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(iu + i), iuv);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(iv + i), ivv);
    if (off)
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(off + i),
                          _mm256_add_epi32(_mm256_mullo_epi32(ivv, _mm256_set1_epi32(stride)),
                                           _mm256_slli_epi32(iuv, 2)));
    if constexpr (kCubic) {
      const __m256 phases = _mm256_set1_ps(static_cast<float>(1 << kPhaseBits));
      const __m256i pu = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(fu, phases), half));
      const __m256i pv = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(fv, phases), half));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(wt + i),
                          _mm256_or_si256(pu, _mm256_slli_epi32(pv, 16)));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(wb + i),
                          _mm256_cvttps_epi32(_mm256_add_ps(wq, half)));
      continue;
    }
    const __m256 top = _mm256_mul_ps(_mm256_sub_ps(one, fv), wq), bot = _mm256_mul_ps(fv, wq);
    const __m256 ifu = _mm256_sub_ps(one, fu);
    const __m256i w00 = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(ifu, top), half));
    const __m256i w01 = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(fu, top), half));
    const __m256i w10 = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(ifu, bot), half));
    const __m256i w11 = _mm256_cvttps_epi32(_mm256_add_ps(_mm256_mul_ps(fu, bot), half));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(wt + i),
                        _mm256_or_si256(w00, _mm256_slli_epi32(w01, 16)));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(wb + i),
                        _mm256_or_si256(w10, _mm256_slli_epi32(w11, 16)));
  }
  for (; i < n; ++i) {
    coord1<kDistort, kCubic>(k, static_cast<float>(x0 + i), iu[i], iv[i], wt[i], wb[i]);
    if (off) off[i] = iv[i] * stride + 4 * iu[i];
  }
}

// The two horizontally adjacent taps at p (8 bytes: RGBA RGBA).
LF_AVX2 inline int64_t taps(const uint8_t* p) {
  int64_t t;
  std::memcpy(&t, p, 8);
  return t;
}

}  // namespace

LF_AVX2 void coords_avx2(bool distort, bool cubic, const Consts& k, int x0, int n, int32_t* iu,
                         int32_t* iv, int32_t* wt, int32_t* wb, int stride, int32_t* off) {
  if (cubic) {
    if (distort)
      coords8<true, true>(k, x0, n, iu, iv, wt, wb, stride, off);
    else
      coords8<false, true>(k, x0, n, iu, iv, wt, wb, stride, off);
  } else if (distort) {
    coords8<true, false>(k, x0, n, iu, iv, wt, wb, stride, off);
  } else {
    coords8<false, false>(k, x0, n, iu, iv, wt, wb, stride, off);
  }
}

// Bicubic. Two pixels per step where all 16 taps of both are inside the
// image (one pixel per 128-bit lane), else one at a time (in both lanes,
// or the reference at the border): each of a pixel's four rows
// is one 16-byte load (taps -1..2), shuffled so that two taps of a channel
// sit side by side, widened to 16 bits and reduced by two madds with the
// pixel's horizontal tap weights to four 32-bit channel sums; those are
// rounded to levels, weighted by the vertical taps and summed (32-bit
// products: the same integers as gather_cubic1), then clamped and scaled by
// the aperture weight.
namespace {

LF_AVX2 inline int pack16(int16_t a, int16_t b) {
  return static_cast<int>(static_cast<uint16_t>(a) |
                          (static_cast<uint32_t>(static_cast<uint16_t>(b)) << 16));
}

LF_AVX2 inline bool inside(int iu, int iv, int width, int height) {
  return iu >= 1 && iu <= width - 3 && iv >= 1 && iv <= height - 3;
}

// Interior pixels a and b (b may be a again), one per 128-bit lane; their
// RGBA bytes in *out_a and *out_b.
LF_AVX2 inline void cubic_two(const uint8_t* src, int stride, const int32_t* iu, const int32_t* iv,
                              const int32_t* phases, const int32_t* wq, const CubicTaps* table,
                              int a, int b, int32_t* out_a, int32_t* out_b) {
  const __m256i pair = _mm256_setr_epi8(0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15, 0, 4,
                                        1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15);
  const __m256i round_c = _mm256_set1_epi32(1 << (kCubicBits - 1));
  const __m256i round_w = _mm256_set1_epi32(1 << (kWeightBits - 1));
  const __m256i zero = _mm256_setzero_si256(), max = _mm256_set1_epi32(255);
  const int16_t* ha = table[phases[a] & 0xffff];
  const int16_t* va = table[(phases[a] >> 16) & 0xffff];
  const int16_t* hb = table[phases[b] & 0xffff];
  const int16_t* vb = table[(phases[b] >> 16) & 0xffff];
  const int a01 = pack16(ha[0], ha[1]), a23 = pack16(ha[2], ha[3]);
  const int b01 = pack16(hb[0], hb[1]), b23 = pack16(hb[2], hb[3]);
  const __m256i h01 = _mm256_setr_epi32(a01, a01, a01, a01, b01, b01, b01, b01);
  const __m256i h23 = _mm256_setr_epi32(a23, a23, a23, a23, b23, b23, b23, b23);
  auto at = [&](int k) {
    return src + static_cast<std::ptrdiff_t>(iv[k] - 1) * stride + 4 * (iu[k] - 1);
  };
  const uint8_t* pa = at(a);
  const uint8_t* pb = at(b);
  __m256i acc = zero;
  for (int j = 0; j < 4; ++j) {
    const std::ptrdiff_t off = static_cast<std::ptrdiff_t>(j) * stride;
    const __m256i rows = _mm256_inserti128_si256(
        _mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(pa + off))),
        _mm_loadu_si128(reinterpret_cast<const __m128i*>(pb + off)), 1);
    const __m256i s = _mm256_shuffle_epi8(rows, pair);
    __m256i r = _mm256_add_epi32(_mm256_madd_epi16(_mm256_unpacklo_epi8(s, zero), h01),
                                 _mm256_madd_epi16(_mm256_unpackhi_epi8(s, zero), h23));
    r = _mm256_srai_epi32(_mm256_add_epi32(r, round_c), kCubicBits);
    const __m256i vj = _mm256_setr_epi32(va[j], va[j], va[j], va[j], vb[j], vb[j], vb[j], vb[j]);
    acc = _mm256_add_epi32(acc, _mm256_mullo_epi32(r, vj));
  }
  acc = _mm256_srai_epi32(_mm256_add_epi32(acc, round_c), kCubicBits);
  acc = _mm256_min_epi32(_mm256_max_epi32(acc, zero), max);
  const __m256i w = _mm256_setr_epi32(wq[a], wq[a], wq[a], wq[a], wq[b], wq[b], wq[b], wq[b]);
  acc = _mm256_srli_epi32(_mm256_add_epi32(_mm256_mullo_epi32(acc, w), round_w), kWeightBits);
  acc = _mm256_packus_epi16(_mm256_packs_epi32(acc, acc), zero);
  *out_a = _mm_cvtsi128_si32(_mm256_castsi256_si128(acc));
  *out_b = _mm_cvtsi128_si32(_mm256_extracti128_si256(acc, 1));
}

}  // namespace

LF_AVX2 void gather_cubic_avx2(const uint8_t* src, int stride, int width, int height, int n,
                               const int32_t* iu, const int32_t* iv, const int32_t* phases,
                               const int32_t* wq, uint8_t* dst) {
  const CubicTaps* table = cubic_taps();
  int i = 0;
  while (i < n) {
    if (!inside(iu[i], iv[i], width, height)) {
      gather_cubic1(src, stride, width, height, iu[i], iv[i], phases[i], wq[i], dst + 4 * i);
      ++i;
      continue;
    }
    // With the next pixel when it is interior too, else alone (twice).
    const bool two = i + 1 < n && inside(iu[i + 1], iv[i + 1], width, height);
    int32_t px[2];
    cubic_two(src, stride, iu, iv, phases, wq, table, i, two ? i + 1 : i, &px[0], &px[1]);
    std::memcpy(dst + 4 * i, px, two ? 8 : 4);
    i += two ? 2 : 1;
  }
}

// Four pixels per step. Each pixel's two top taps become, after a byte
// shuffle (left and right tap of each channel side by side) and widening to
// 16 bits, one 128-bit lane that a single madd with the pixel's packed
// (w00, w01) turns into four 32-bit channel sums; likewise the bottom taps.
// Two pixels share a 256-bit register (one per lane).
LF_AVX2 void gather_avx2(const uint8_t* src, int stride, int n, const int32_t* off,
                         const int32_t* iu, const int32_t* iv, const int32_t* wtop,
                         const int32_t* wbot, uint8_t* dst) {
  const __m128i pair = _mm_setr_epi8(0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15);
  const __m256i round = _mm256_set1_epi32(1 << (kWeightBits - 1));
  const __m256i lo2 = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
  const __m256i hi2 = _mm256_setr_epi32(2, 2, 2, 2, 3, 3, 3, 3);
  const __m256i order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    const uint8_t* p[4];
    for (int j = 0; j < 4; ++j) p[j] = src + off[i + j];
    const __m256i t01 =
        _mm256_cvtepu8_epi16(_mm_shuffle_epi8(_mm_set_epi64x(taps(p[1]), taps(p[0])), pair));
    const __m256i t23 =
        _mm256_cvtepu8_epi16(_mm_shuffle_epi8(_mm_set_epi64x(taps(p[3]), taps(p[2])), pair));
    const __m256i b01 = _mm256_cvtepu8_epi16(
        _mm_shuffle_epi8(_mm_set_epi64x(taps(p[1] + stride), taps(p[0] + stride)), pair));
    const __m256i b23 = _mm256_cvtepu8_epi16(
        _mm_shuffle_epi8(_mm_set_epi64x(taps(p[3] + stride), taps(p[2] + stride)), pair));
    const __m256i wt =
        _mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(wtop + i)));
    const __m256i wb =
        _mm256_castsi128_si256(_mm_loadu_si128(reinterpret_cast<const __m128i*>(wbot + i)));
    __m256i a01 = _mm256_add_epi32(_mm256_madd_epi16(t01, _mm256_permutevar8x32_epi32(wt, lo2)),
                                   _mm256_madd_epi16(b01, _mm256_permutevar8x32_epi32(wb, lo2)));
    __m256i a23 = _mm256_add_epi32(_mm256_madd_epi16(t23, _mm256_permutevar8x32_epi32(wt, hi2)),
                                   _mm256_madd_epi16(b23, _mm256_permutevar8x32_epi32(wb, hi2)));
    a01 = _mm256_srli_epi32(_mm256_add_epi32(a01, round), kWeightBits);
    a23 = _mm256_srli_epi32(_mm256_add_epi32(a23, round), kWeightBits);
    // Lanes hold pixels (0 | 1) and (2 | 3); packing interleaves them as
    // 0 2 | 1 3 per lane, and the final permute restores 0 1 2 3.
    __m256i px = _mm256_packs_epi32(a01, a23);
    px = _mm256_packus_epi16(px, px);
    px = _mm256_permutevar8x32_epi32(px, order);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + 4 * i), _mm256_castsi256_si128(px));
  }
  for (; i < n; ++i) gather1(src, stride, iu[i], iv[i], wtop[i], wbot[i], dst + 4 * i);
}

}  // namespace lf::kernels

#endif  // LF_X86_SIMD
