// AVX-512 versions of the fragment kernel's coordinate pass and bilinear
// gather (lf/render/render_kernels.h): sixteen pixels per step, the
// comparisons in mask registers; eight, four to a register. The bicubic
// gather stays AVX2's (every AVX-512 CPU has AVX2). Compiled
// for AVX-512 (F, DQ, BW, VL) by function attribute and called only after a
// run-time check (render.cpp). The library is built with
// -ffp-contract=off (lib/meson.build): with AVX-512 the compiler could fuse
// a product and a sum, and every product is rounded as in the scalar
// reference, so the output stays bit-identical (tests/test_render.cpp).
// Measured on a 2-core AMD EPYC (Zen 4): plan + render of a 64-camera view
// 0.85-0.92x AVX2's time with the taps read by scalar loads, 1.20-1.38x by
// the gather instruction (lf/render/render.h TapLoads: timed at run time).
#include "lf/render/render_kernels.h"

#ifdef LF_X86_SIMD
#include <immintrin.h>

#include <cstring>

#define LF_AVX512 __attribute__((target("avx512f,avx512dq,avx512bw,avx512vl,avx2")))

namespace lf::kernels {

namespace {

template <bool kDistort, bool kCubic>
LF_AVX512 void coords16(const Consts& k, int x0, int n, int32_t* iu, int32_t* iv, int32_t* wt,
                        int32_t* wb, int stride, int32_t* off) {
  const __m512 one = _mm512_set1_ps(1.0f), zero = _mm512_setzero_ps();
  const __m512 half = _mm512_set1_ps(0.5f), mhalf = _mm512_set1_ps(-0.5f);
  const __m512 scale = _mm512_set1_ps(static_cast<float>(1 << kWeightBits));
  const __m512 xa = _mm512_set1_ps(k.xa), xb = _mm512_set1_ps(k.xb);
  const __m512 ya = _mm512_set1_ps(k.ya), yb = _mm512_set1_ps(k.yb);
  const __m512 za = _mm512_set1_ps(k.za), zb = _mm512_set1_ps(k.zb);
  const __m512 na = _mm512_set1_ps(k.na), nb = _mm512_set1_ps(k.nb);
  const __m512 da = _mm512_set1_ps(k.da), db = _mm512_set1_ps(k.db);
  const __m512 umax = _mm512_set1_ps(k.umax), vmax = _mm512_set1_ps(k.vmax);
  const __m512 uclamp = _mm512_set1_ps(k.uclamp), vclamp = _mm512_set1_ps(k.vclamp);
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  int i = 0;
  for (; i + 16 <= n; i += 16) {
    const __m512 x = _mm512_cvtepi32_ps(_mm512_add_epi32(_mm512_set1_epi32(x0 + i), lane));
    const __m512 X = _mm512_add_ps(_mm512_mul_ps(xa, x), xb);
    const __m512 Y = _mm512_add_ps(_mm512_mul_ps(ya, x), yb);
    const __m512 Z = _mm512_add_ps(_mm512_mul_ps(za, x), zb);
    const __m512 iz = _mm512_div_ps(one, Z);
    __m512 u = _mm512_mul_ps(X, iz), v = _mm512_mul_ps(Y, iz);
    __mmask16 ok = _mm512_cmp_ps_mask(Z, zero, _CMP_GT_OQ);
    if constexpr (kDistort) {
      const __m512 cx = _mm512_set1_ps(k.cx), cy = _mm512_set1_ps(k.cy);
      const __m512 xn = _mm512_mul_ps(_mm512_sub_ps(u, cx), _mm512_set1_ps(k.ifx));
      const __m512 yn = _mm512_mul_ps(_mm512_sub_ps(v, cy), _mm512_set1_ps(k.ify));
      const __m512 r2 = _mm512_add_ps(_mm512_mul_ps(xn, xn), _mm512_mul_ps(yn, yn));
      const __m512 f = _mm512_add_ps(
          one, _mm512_mul_ps(r2, _mm512_add_ps(_mm512_set1_ps(k.k1),
                                               _mm512_mul_ps(_mm512_set1_ps(k.k2), r2))));
      ok &= _mm512_cmp_ps_mask(r2, _mm512_set1_ps(k.r2max), _CMP_LE_OQ);
      u = _mm512_add_ps(_mm512_mul_ps(_mm512_set1_ps(k.fx), _mm512_mul_ps(xn, f)), cx);
      v = _mm512_add_ps(_mm512_mul_ps(_mm512_set1_ps(k.fy), _mm512_mul_ps(yn, f)), cy);
    }
    __m512 w = _mm512_div_ps(_mm512_add_ps(_mm512_mul_ps(na, x), nb),
                             _mm512_add_ps(_mm512_mul_ps(da, x), db));
    w = _mm512_min_ps(one, w);
    ok &= _mm512_cmp_ps_mask(w, zero, _CMP_GT_OQ);
    ok &= _mm512_cmp_ps_mask(u, mhalf, _CMP_GE_OQ) & _mm512_cmp_ps_mask(u, umax, _CMP_LE_OQ);
    ok &= _mm512_cmp_ps_mask(v, mhalf, _CMP_GE_OQ) & _mm512_cmp_ps_mask(v, vmax, _CMP_LE_OQ);
    u = _mm512_maskz_mov_ps(ok, u);
    v = _mm512_maskz_mov_ps(ok, v);
    w = _mm512_maskz_mov_ps(ok, w);
    u = _mm512_min_ps(uclamp, _mm512_max_ps(zero, u));
    v = _mm512_min_ps(vclamp, _mm512_max_ps(zero, v));
    const __m512i iuv = _mm512_cvttps_epi32(u), ivv = _mm512_cvttps_epi32(v);
    const __m512 fu = _mm512_sub_ps(u, _mm512_cvtepi32_ps(iuv));
    const __m512 fv = _mm512_sub_ps(v, _mm512_cvtepi32_ps(ivv));
    const __m512 wq = _mm512_mul_ps(w, scale);
    _mm512_storeu_si512(iu + i, iuv);
    _mm512_storeu_si512(iv + i, ivv);
    if (off)
      _mm512_storeu_si512(off + i,
                          _mm512_add_epi32(_mm512_mullo_epi32(ivv, _mm512_set1_epi32(stride)),
                                           _mm512_slli_epi32(iuv, 2)));
    if constexpr (kCubic) {
      const __m512 phases = _mm512_set1_ps(static_cast<float>(1 << kPhaseBits));
      const __m512i pu = _mm512_cvttps_epi32(_mm512_add_ps(_mm512_mul_ps(fu, phases), half));
      const __m512i pv = _mm512_cvttps_epi32(_mm512_add_ps(_mm512_mul_ps(fv, phases), half));
      _mm512_storeu_si512(wt + i, _mm512_or_si512(pu, _mm512_slli_epi32(pv, 16)));
      _mm512_storeu_si512(wb + i, _mm512_cvttps_epi32(_mm512_add_ps(wq, half)));
      continue;
    }
    const __m512 top = _mm512_mul_ps(_mm512_sub_ps(one, fv), wq), bot = _mm512_mul_ps(fv, wq);
    const __m512 ifu = _mm512_sub_ps(one, fu);
    const __m512i w00 = _mm512_cvttps_epi32(_mm512_add_ps(_mm512_mul_ps(ifu, top), half));
    const __m512i w01 = _mm512_cvttps_epi32(_mm512_add_ps(_mm512_mul_ps(fu, top), half));
    const __m512i w10 = _mm512_cvttps_epi32(_mm512_add_ps(_mm512_mul_ps(ifu, bot), half));
    const __m512i w11 = _mm512_cvttps_epi32(_mm512_add_ps(_mm512_mul_ps(fu, bot), half));
    _mm512_storeu_si512(wt + i, _mm512_or_si512(w00, _mm512_slli_epi32(w01, 16)));
    _mm512_storeu_si512(wb + i, _mm512_or_si512(w10, _mm512_slli_epi32(w11, 16)));
  }
  // The rest (fewer than 16) by the AVX2 pass: eight at a time, then the
  // reference.
  if (i < n)
    coords_avx2(kDistort, kCubic, k, x0 + i, n - i, iu + i, iv + i, wt + i, wb + i, stride,
                off ? off + i : nullptr);
}

// Four pixels' bilinear sums: each pixel's two taps of a row (8 bytes:
// RGBA RGBA; `t8` the four pixels' of the top row, `b8` of the bottom; after
// the byte shuffle, left and right tap of each channel side by side)
// widened to 16 bits fill one 128-bit lane, and one madd with the pixel's
// packed weights gives its four channel sums; top and bottom rows added,
// rounded, and saturated to bytes in pixel order.
LF_AVX512 inline __m128i four(__m256i t8, __m256i b8, const int32_t* wtop, const int32_t* wbot) {
  const __m256i pair = _mm256_setr_epi8(0, 4, 1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15, 0, 4,
                                        1, 5, 2, 6, 3, 7, 8, 12, 9, 13, 10, 14, 11, 15);
  const __m512i spread = _mm512_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3);
  const __m512i round = _mm512_set1_epi32(1 << (kWeightBits - 1));
  const __m512i t = _mm512_cvtepu8_epi16(_mm256_shuffle_epi8(t8, pair));
  const __m512i b = _mm512_cvtepu8_epi16(_mm256_shuffle_epi8(b8, pair));
  const __m512i wt = _mm512_permutexvar_epi32(
      spread, _mm512_castsi128_si512(_mm_loadu_si128(reinterpret_cast<const __m128i*>(wtop))));
  const __m512i wb = _mm512_permutexvar_epi32(
      spread, _mm512_castsi128_si512(_mm_loadu_si128(reinterpret_cast<const __m128i*>(wbot))));
  __m512i a = _mm512_add_epi32(_mm512_madd_epi16(t, wt), _mm512_madd_epi16(b, wb));
  a = _mm512_srli_epi32(_mm512_add_epi32(a, round), kWeightBits);
  return _mm512_cvtusepi32_epi8(a);
}

// Eight pixels per step (two of four), the rest by the AVX2 gather. The
// sums and their rounding are gather_avx2's, so are the bytes: the sums are
// never negative, so saturating them to bytes at once gives what its signed
// then unsigned packs give. kHardware: each row's eight 8-byte tap pairs
// by one AVX-512 gather instruction; otherwise by eight scalar loads
// stored and loaded back as one vector (what the AVX2 gather does four at
// a time). Which is faster depends on the CPU (lf/render/render.h
// TapLoads), the bytes do not.
template <bool kHardware>
LF_AVX512 void gather8(const uint8_t* src, int stride, int n, const int32_t* off, const int32_t* iu,
                       const int32_t* iv, const int32_t* wtop, const int32_t* wbot, uint8_t* dst) {
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    // Each pixel's two taps of its top row, then of its bottom row: 8 bytes
    // each, read at the pixels' offsets.
    __m512i top, bot;
    if constexpr (kHardware) {
      const __m256i o = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(off + i));
      top = _mm512_i32gather_epi64(o, src, 1);
      bot = _mm512_i32gather_epi64(o, src + stride, 1);
    } else {
      alignas(64) int64_t t[8], b[8];
      for (int j = 0; j < 8; ++j) {
        std::memcpy(&t[j], src + off[i + j], 8);
        std::memcpy(&b[j], src + off[i + j] + stride, 8);
      }
      top = _mm512_load_si512(t);
      bot = _mm512_load_si512(b);
    }
    _mm_storeu_si128(
        reinterpret_cast<__m128i*>(dst + 4 * i),
        four(_mm512_castsi512_si256(top), _mm512_castsi512_si256(bot), wtop + i, wbot + i));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(dst + 4 * i + 16),
                     four(_mm512_extracti64x4_epi64(top, 1), _mm512_extracti64x4_epi64(bot, 1),
                          wtop + i + 4, wbot + i + 4));
  }
  if (i < n)
    gather_avx2(src, stride, n - i, off + i, iu + i, iv + i, wtop + i, wbot + i, dst + 4 * i);
}

}  // namespace

LF_AVX512 void gather_avx512(bool hardware, const uint8_t* src, int stride, int n,
                             const int32_t* off, const int32_t* iu, const int32_t* iv,
                             const int32_t* wtop, const int32_t* wbot, uint8_t* dst) {
  (hardware ? gather8<true> : gather8<false>)(src, stride, n, off, iu, iv, wtop, wbot, dst);
}

LF_AVX512 void coords_avx512(bool distort, bool cubic, const Consts& k, int x0, int n, int32_t* iu,
                             int32_t* iv, int32_t* wt, int32_t* wb, int stride, int32_t* off) {
  if (cubic) {
    if (distort)
      coords16<true, true>(k, x0, n, iu, iv, wt, wb, stride, off);
    else
      coords16<false, true>(k, x0, n, iu, iv, wt, wb, stride, off);
  } else if (distort) {
    coords16<true, false>(k, x0, n, iu, iv, wt, wb, stride, off);
  } else {
    coords16<false, false>(k, x0, n, iu, iv, wt, wb, stride, off);
  }
}

}  // namespace lf::kernels

#endif  // LF_X86_SIMD
