#include "lf/render.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "lf/projection.h"

#if defined(__SSE2__) && !defined(LF_NO_SIMD)
#include <emmintrin.h>
#define LF_SSE2 1
#endif

namespace lf {

namespace {

constexpr int kBlock = 64;
constexpr int kWeightBits = 14;  // bilinear weights in 1/16384

// Pass 1: sampling coordinates and packed fixed-point bilinear weights with
// the aperture weight folded in. Writes integer tap positions (iu, iv) and
// the weight pairs (w00 | w01 << 16, w10 | w11 << 16). The scalar code is the
// reference; the SSE2 path evaluates the same expressions in the same order
// (min/max operand order included, so NaNs behave alike): bit-identical.
struct Consts {
  float xa, xb, ya, yb, za, zb, na, nb, da, db;
  float umax, vmax, uclamp, vclamp;
  float fx, fy, cx, cy, ifx, ify, k1, k2, r2max;
};

template <bool kDistort>
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
  const float top = (1.0f - fv) * wq, bot = fv * wq;
  const int w00 = static_cast<int>((1.0f - fu) * top + 0.5f);
  const int w01 = static_cast<int>(fu * top + 0.5f);
  const int w10 = static_cast<int>((1.0f - fu) * bot + 0.5f);
  const int w11 = static_cast<int>(fu * bot + 0.5f);
  iu_out = iu;
  iv_out = iv;
  wt = w00 | (w01 << 16);
  wb = w10 | (w11 << 16);
}

template <bool kDistort>
void coords(bool simd, const Consts& k, int x0, int n, int32_t* iu, int32_t* iv, int32_t* wt,
            int32_t* wb) {
  int i = 0;
#ifdef LF_SSE2
  const __m128 one = _mm_set1_ps(1.0f), zero = _mm_setzero_ps(), half = _mm_set1_ps(0.5f);
  const __m128 mhalf = _mm_set1_ps(-0.5f),
               scale = _mm_set1_ps(static_cast<float>(1 << kWeightBits));
  auto s = [](float f) { return _mm_set1_ps(f); };
  const __m128 xa = s(k.xa), xb = s(k.xb), ya = s(k.ya), yb = s(k.yb), za = s(k.za), zb = s(k.zb);
  const __m128 na = s(k.na), nb = s(k.nb), da = s(k.da), db = s(k.db);
  const __m128 umax = s(k.umax), vmax = s(k.vmax), uclamp = s(k.uclamp), vclamp = s(k.vclamp);
  for (; simd && i + 4 <= n; i += 4) {
    const __m128 x =
        _mm_cvtepi32_ps(_mm_add_epi32(_mm_set1_epi32(x0 + i), _mm_setr_epi32(0, 1, 2, 3)));
    const __m128 X = _mm_add_ps(_mm_mul_ps(xa, x), xb);
    const __m128 Y = _mm_add_ps(_mm_mul_ps(ya, x), yb);
    const __m128 Z = _mm_add_ps(_mm_mul_ps(za, x), zb);
    const __m128 iz = _mm_div_ps(one, Z);
    __m128 u = _mm_mul_ps(X, iz), v = _mm_mul_ps(Y, iz);
    __m128 ok = _mm_cmpgt_ps(Z, zero);
    if constexpr (kDistort) {
      const __m128 xn = _mm_mul_ps(_mm_sub_ps(u, s(k.cx)), s(k.ifx));
      const __m128 yn = _mm_mul_ps(_mm_sub_ps(v, s(k.cy)), s(k.ify));
      const __m128 r2 = _mm_add_ps(_mm_mul_ps(xn, xn), _mm_mul_ps(yn, yn));
      const __m128 f =
          _mm_add_ps(one, _mm_mul_ps(r2, _mm_add_ps(s(k.k1), _mm_mul_ps(s(k.k2), r2))));
      ok = _mm_and_ps(ok, _mm_cmple_ps(r2, s(k.r2max)));
      u = _mm_add_ps(_mm_mul_ps(s(k.fx), _mm_mul_ps(xn, f)), s(k.cx));
      v = _mm_add_ps(_mm_mul_ps(s(k.fy), _mm_mul_ps(yn, f)), s(k.cy));
    }
    __m128 w = _mm_div_ps(_mm_add_ps(_mm_mul_ps(na, x), nb), _mm_add_ps(_mm_mul_ps(da, x), db));
    w = _mm_min_ps(one, w);
    ok = _mm_and_ps(ok, _mm_cmpgt_ps(w, zero));
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmpge_ps(u, mhalf), _mm_cmple_ps(u, umax)));
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmpge_ps(v, mhalf), _mm_cmple_ps(v, vmax)));
    u = _mm_and_ps(ok, u);
    v = _mm_and_ps(ok, v);
    w = _mm_and_ps(ok, w);
    u = _mm_min_ps(uclamp, _mm_max_ps(zero, u));
    v = _mm_min_ps(vclamp, _mm_max_ps(zero, v));
    const __m128i iuv = _mm_cvttps_epi32(u), ivv = _mm_cvttps_epi32(v);
    const __m128 fu = _mm_sub_ps(u, _mm_cvtepi32_ps(iuv)), fv = _mm_sub_ps(v, _mm_cvtepi32_ps(ivv));
    const __m128 wq = _mm_mul_ps(w, scale);
    const __m128 top = _mm_mul_ps(_mm_sub_ps(one, fv), wq), bot = _mm_mul_ps(fv, wq);
    const __m128 ifu = _mm_sub_ps(one, fu);
    const __m128i w00 = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(ifu, top), half));
    const __m128i w01 = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(fu, top), half));
    const __m128i w10 = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(ifu, bot), half));
    const __m128i w11 = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(fu, bot), half));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(iu + i), iuv);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(iv + i), ivv);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(wt + i),
                     _mm_or_si128(w00, _mm_slli_epi32(w01, 16)));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(wb + i),
                     _mm_or_si128(w10, _mm_slli_epi32(w11, 16)));
  }
#endif
  for (; i < n; ++i) coord1<kDistort>(k, static_cast<float>(x0 + i), iu[i], iv[i], wt[i], wb[i]);
}

// Pass 2: gather four taps per pixel and blend in fixed point.
void gather(bool simd, const uint8_t* src, int stride, int n, const int32_t* iu, const int32_t* iv,
            const int32_t* wtop, const int32_t* wbot, uint8_t* dst) {
#ifdef LF_SSE2
  const __m128i zero = _mm_setzero_si128();
  const __m128i round = _mm_set1_epi32(1 << (kWeightBits - 1));
  for (int i = 0; simd && i < n; ++i) {
    const uint8_t* p = src + static_cast<ptrdiff_t>(iv[i]) * stride + 4 * iu[i];
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
  if (simd) return;
#endif
  for (int i = 0; i < n; ++i) {
    const uint8_t* p = src + static_cast<ptrdiff_t>(iv[i]) * stride + 4 * iu[i];
    const int w00 = wtop[i] & 0xffff, w01 = (wtop[i] >> 16) & 0xffff;
    const int w10 = wbot[i] & 0xffff, w11 = (wbot[i] >> 16) & 0xffff;
    for (int ch = 0; ch < 4; ++ch) {
      const int acc = p[ch] * w00 + p[4 + ch] * w01 + p[stride + ch] * w10 +
                      p[stride + 4 + ch] * w11 + (1 << (kWeightBits - 1));
      dst[4 * i + ch] = static_cast<uint8_t>(std::min(255, acc >> kWeightBits));
    }
  }
}

}  // namespace

bool simd_available() {
#ifdef LF_SSE2
  return true;
#else
  return false;
#endif
}

void render_fragment(const FragmentPlan& plan, const Camera& cam, const cv::Mat& image,
                     Fragment& out, Kernel kernel) {
  const bool simd = kernel == Kernel::kBest && simd_available();
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

  const Intrinsics& K = cam.intrinsics;
  const bool distort = K.has_distortion();
  Consts k{};
  k.umax = static_cast<float>(cam.width) - 0.5f;
  k.vmax = static_cast<float>(cam.height) - 0.5f;
  k.uclamp = static_cast<float>(cam.width - 1) - 1.0f / 1024.0f;
  k.vclamp = static_cast<float>(cam.height - 1) - 1.0f / 1024.0f;
  k.fx = static_cast<float>(K.fx), k.fy = static_cast<float>(K.fy);
  k.cx = static_cast<float>(K.cx), k.cy = static_cast<float>(K.cy);
  k.ifx = static_cast<float>(1.0 / K.fx), k.ify = static_cast<float>(1.0 / K.fy);
  k.k1 = static_cast<float>(K.k1), k.k2 = static_cast<float>(K.k2);
  const double rf = distortion_fold_radius(K);
  k.r2max = std::isfinite(rf) ? static_cast<float>(rf * rf) : INFINITY;
  const int stride = static_cast<int>(image.step[0]);

  alignas(16) int32_t iu[kBlock], iv[kBlock], wtop[kBlock], wbot[kBlock];
  for (const Run& run : plan.runs) {
    const FragmentPiece& pc = plan.pieces[run.piece];
    const double y = run.y;
    const cv::Matx33d& H = pc.H;
    k.xa = static_cast<float>(H(0, 0)), k.xb = static_cast<float>(H(0, 1) * y + H(0, 2));
    k.ya = static_cast<float>(H(1, 0)), k.yb = static_cast<float>(H(1, 1) * y + H(1, 2));
    k.za = static_cast<float>(H(2, 0)), k.zb = static_cast<float>(H(2, 1) * y + H(2, 2));
    k.na = static_cast<float>(pc.weight_num.a);
    k.nb = static_cast<float>(pc.weight_num.b * y + pc.weight_num.c);
    k.da = static_cast<float>(pc.weight_den.a);
    k.db = static_cast<float>(pc.weight_den.b * y + pc.weight_den.c);
    const int r = run.y - plan.rect.y;
    uint8_t* row = out.pixels.data() + row_offset[r];
    for (int x = run.x0; x < run.x1; x += kBlock) {
      const int n = std::min(kBlock, run.x1 - x);
      if (distort)
        coords<true>(simd, k, x, n, iu, iv, wtop, wbot);
      else
        coords<false>(simd, k, x, n, iu, iv, wtop, wbot);
      gather(simd, image.data, stride, n, iu, iv, wtop, wbot, row + 4 * (x - plan.row_spans[r][0]));
    }
  }
}

}  // namespace lf
