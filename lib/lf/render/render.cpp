#include "lf/render/render.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "lf/geometry/projection.h"
#include "lf/render/render_kernels.h"

#ifdef LF_X86_SIMD
#include <emmintrin.h>
#endif

namespace lf {

namespace {

using kernels::Consts;
using kernels::coord1;
using kernels::kBlock;
using kernels::kWeightBits;

// Pass 1 (lf/render/render_kernels.h): SSE2, four pixels per step, the same
// expressions in the same order as the scalar reference: bit-identical.
template <bool kDistort, bool kCubic>
void coords_sse2(bool simd, const Consts& k, int x0, int n, int32_t* iu, int32_t* iv, int32_t* wt,
                 int32_t* wb) {
  int i = 0;
  (void)simd;
#ifdef LF_X86_SIMD
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
    _mm_storeu_si128(reinterpret_cast<__m128i*>(iu + i), iuv);
    _mm_storeu_si128(reinterpret_cast<__m128i*>(iv + i), ivv);
    if constexpr (kCubic) {
      const __m128 phases = _mm_set1_ps(static_cast<float>(1 << kernels::kPhaseBits));
      const __m128i pu = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(fu, phases), half));
      const __m128i pv = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(fv, phases), half));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(wt + i),
                       _mm_or_si128(pu, _mm_slli_epi32(pv, 16)));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(wb + i), _mm_cvttps_epi32(_mm_add_ps(wq, half)));
      continue;
    }
    const __m128 top = _mm_mul_ps(_mm_sub_ps(one, fv), wq), bot = _mm_mul_ps(fv, wq);
    const __m128 ifu = _mm_sub_ps(one, fu);
    const __m128i w00 = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(ifu, top), half));
    const __m128i w01 = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(fu, top), half));
    const __m128i w10 = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(ifu, bot), half));
    const __m128i w11 = _mm_cvttps_epi32(_mm_add_ps(_mm_mul_ps(fu, bot), half));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(wt + i),
                     _mm_or_si128(w00, _mm_slli_epi32(w01, 16)));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(wb + i),
                     _mm_or_si128(w10, _mm_slli_epi32(w11, 16)));
  }
#endif
  for (; i < n; ++i)
    coord1<kDistort, kCubic>(k, static_cast<float>(x0 + i), iu[i], iv[i], wt[i], wb[i]);
}

// Pass 2: gather four taps per pixel and blend in fixed point (SSE2: one
// pixel per step).
void gather_sse2(bool simd, const uint8_t* src, int stride, int n, const int32_t* iu,
                 const int32_t* iv, const int32_t* wtop, const int32_t* wbot, uint8_t* dst) {
  (void)simd;
#ifdef LF_X86_SIMD
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
  for (int i = 0; i < n; ++i)
    kernels::gather1(src, stride, iu[i], iv[i], wtop[i], wbot[i], dst + 4 * i);
}

}  // namespace

namespace kernels {
// Keys' cubic convolution kernel with a = -0.5 at phases t = k / 256,
// rounded to 1/4096 with the largest tap absorbing the rounding, so each
// entry sums to 4096 exactly (a flat image stays flat).
const CubicTaps* cubic_taps() {
  static const auto table = [] {
    std::array<std::array<int16_t, 4>, (1 << kPhaseBits) + 1> t{};
    for (int k = 0; k <= (1 << kPhaseBits); ++k) {
      const double x = static_cast<double>(k) / (1 << kPhaseBits);
      const double w[4] = {((-0.5 * x + 1.0) * x - 0.5) * x, (1.5 * x - 2.5) * x * x + 1.0,
                           ((-1.5 * x + 2.0) * x + 0.5) * x, (0.5 * x - 0.5) * x * x};
      int sum = 0, big = 0;
      for (int j = 0; j < 4; ++j) {
        t[k][j] = static_cast<int16_t>(std::lround(w[j] * (1 << kCubicBits)));
        sum += t[k][j];
        if (w[j] > w[big]) big = j;
      }
      t[k][big] = static_cast<int16_t>(t[k][big] + ((1 << kCubicBits) - sum));
    }
    return t;
  }();
  return reinterpret_cast<const CubicTaps*>(table.data());
}
}  // namespace kernels

bool simd_available() {
  return kernel_available(Kernel::kSse2);
}

bool kernel_available(Kernel kernel) {
  switch (kernel) {
    case Kernel::kBest:
    case Kernel::kScalar:
      return true;
#ifdef LF_X86_SIMD
    case Kernel::kSse2:
      return true;  // the x86-64 baseline
    case Kernel::kAvx2: {
      static const bool avx2 = __builtin_cpu_supports("avx2");
      return avx2;
    }
    case Kernel::kAvx512: {
      static const bool avx512 =
          __builtin_cpu_supports("avx2") && __builtin_cpu_supports("avx512f") &&
          __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw") &&
          __builtin_cpu_supports("avx512vl");
      return avx512;
    }
#else
    case Kernel::kSse2:
    case Kernel::kAvx2:
    case Kernel::kAvx512:
      return false;
#endif
  }
  return false;
}

Kernel best_kernel() {
  for (Kernel k : {Kernel::kAvx512, Kernel::kAvx2, Kernel::kSse2})
    if (kernel_available(k)) return k;
  return Kernel::kScalar;
}

namespace {

std::atomic<TapLoads> g_tap_loads{TapLoads::kAuto};

#ifdef LF_X86_SIMD
// The faster way for this CPU: both run on the same synthetic warp (a
// 256 x 128 image of noise, blocks of kBlock pixels stepping 0.9 pixel
// across and 0.1 down, a block 1.7 rows below the last, as a fragment's rows
// walk a camera image), alternately, nine trials each of 48 blocks; the
// faster minimum wins.
TapLoads time_tap_loads() {
  if (!kernel_available(Kernel::kAvx512)) return TapLoads::kLoads;
  constexpr int kW = 256, kH = 128, kStride = 4 * kW, kBlocks = 48;
  std::vector<uint8_t> image(static_cast<size_t>(kStride) * (kH + 1));
  uint32_t seed = 12345;
  for (uint8_t& b : image) b = static_cast<uint8_t>((seed = seed * 1664525u + 1013904223u) >> 24);
  std::vector<int32_t> off(static_cast<size_t>(kBlocks) * kBlock), iu(off.size()), iv(off.size());
  std::vector<int32_t> wt(off.size(), 0x10003000), wb(off.size(), 0x08000800);
  for (int b = 0; b < kBlocks; ++b)
    for (int i = 0; i < kBlock; ++i) {
      const size_t j = static_cast<size_t>(b) * kBlock + i;
      iu[j] = static_cast<int32_t>(20 + 0.9 * i + 0.15 * b);
      iv[j] = static_cast<int32_t>(4 + 1.7 * b + 0.1 * i);
      off[j] = iv[j] * kStride + 4 * iu[j];
    }
  std::vector<uint8_t> dst(4 * off.size());
  using Clock = std::chrono::steady_clock;
  auto trial = [&](bool hardware) {
    const auto t0 = Clock::now();
    for (int b = 0; b < kBlocks; ++b) {
      const size_t j = static_cast<size_t>(b) * kBlock;
      kernels::gather_avx512(hardware, image.data(), kStride, kBlock, off.data() + j, iu.data() + j,
                             iv.data() + j, wt.data() + j, wb.data() + j, dst.data() + 4 * j);
    }
    return std::chrono::duration<double>(Clock::now() - t0).count();
  };
  trial(true), trial(false);  // warm: caches, the vector unit's power state
  double best[2] = {1e9, 1e9};
  for (int t = 0; t < 9; ++t)
    for (int hardware = 0; hardware < 2; ++hardware)
      best[hardware] = std::min(best[hardware], trial(hardware != 0));
  return best[1] < best[0] ? TapLoads::kGather : TapLoads::kLoads;
}
#endif

}  // namespace

void set_tap_loads(TapLoads t) {
  g_tap_loads.store(t, std::memory_order_relaxed);
}

TapLoads tap_loads() {
  const TapLoads t = g_tap_loads.load(std::memory_order_relaxed);
  if (t != TapLoads::kAuto) return t;
#ifdef LF_X86_SIMD
  static const TapLoads timed = time_tap_loads();
  return timed;
#else
  return TapLoads::kLoads;
#endif
}

const char* tap_loads_name(TapLoads t) {
  switch (t) {
    case TapLoads::kAuto:
      return "self-timed";
    case TapLoads::kGather:
      return "gather instruction";
    case TapLoads::kLoads:
      return "scalar loads";
  }
  return "?";
}

const char* kernel_name(Kernel kernel) {
  switch (kernel) {
    case Kernel::kBest:
      return kernel_name(best_kernel());
    case Kernel::kScalar:
      return "scalar";
    case Kernel::kSse2:
      return "sse2";
    case Kernel::kAvx2:
      return "avx2";
    case Kernel::kAvx512:
      return "avx512";
  }
  return "?";
}

void describe_fragment(const FragmentPlan& plan, Fragment& out) {
  out.camera_id = static_cast<uint32_t>(plan.camera_id);
  out.layer = static_cast<uint8_t>(plan.layer);
  out.out_width = plan.out_width;
  out.out_height = plan.out_height;
  out.rect = plan.rect;
  out.spans.resize(plan.row_spans.size());
  for (size_t r = 0; r < plan.row_spans.size(); ++r)
    out.spans[r] = {static_cast<uint16_t>(plan.row_spans[r][0]),
                    static_cast<uint16_t>(plan.row_spans[r][1])};
  out.pixels.clear();
}

void render_fragment(const FragmentPlan& plan, const Camera& cam, const cv::Mat& image,
                     Fragment& out, Kernel kernel) {
  describe_fragment(plan, out);
  out.camera_id = static_cast<uint32_t>(cam.id);
  out.pixels.resize(4 * plan.pixel_count());
  render_pixels(plan, cam, image, out.pixels.data(), kernel);
}

void render_pixels(const FragmentPlan& plan, const Camera& cam, const cv::Mat& image,
                   uint8_t* pixels, Kernel kernel) {
  render_rows(plan, cam, image, 0, static_cast<int>(plan.row_spans.size()), pixels, kernel);
}

void render_rows(const FragmentPlan& plan, const Camera& cam, const cv::Mat& image, int r0, int r1,
                 uint8_t* pixels, Kernel kernel, size_t row_bytes) {
  if (r0 < 0 || r1 > static_cast<int>(plan.row_spans.size()) || r0 > r1)
    throw std::invalid_argument("render_rows: rows " + std::to_string(r0) + ".." +
                                std::to_string(r1) + " are not within the plan's " +
                                std::to_string(plan.row_spans.size()));
  if (row_bytes != 0 && row_bytes < 4 * static_cast<size_t>(plan.rect.width))
    throw std::invalid_argument("render_rows: " + std::to_string(row_bytes) +
                                " bytes a row is less than the rect's " +
                                std::to_string(4 * plan.rect.width));
  if (kernel == Kernel::kBest) kernel = best_kernel();
  if (!kernel_available(kernel))
    throw std::invalid_argument(std::string("render_fragment: the ") + kernel_name(kernel) +
                                " kernel is not available on this CPU or build");
  if (image.type() != CV_8UC4)
    throw std::invalid_argument("render_fragment: camera " + std::to_string(cam.id) +
                                ": image must be 8-bit 4-channel (CV_8UC4)");
  if (image.cols != cam.width || image.rows != cam.height)
    throw std::invalid_argument("render_fragment: camera " + std::to_string(cam.id) + ": image " +
                                std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                " does not match the rig's " + std::to_string(cam.width) + "x" +
                                std::to_string(cam.height));
  // Each row's pixels start where the rows before it end; the gaps between
  // a row's runs (and any span pixel no run covers) are zeroed as the rows
  // are walked, so every byte is written once.
  // (With row_bytes, each row starts at its own place in the rect's image.)
  const auto& spans = plan.row_spans;
  auto row_start = [&](int r) {
    return pixels + static_cast<size_t>(r - r0) * row_bytes + 4 * (spans[r][0] - plan.rect.x);
  };
  uint8_t* row = row_bytes && r0 < r1 ? row_start(r0) : pixels;  // start of row `cur`
  int cur = r0, cursor = r0 < r1 ? spans[r0][0] : 0;
  auto finish_rows_before = [&](int r) {
    for (; cur < r; ++cur) {
      std::memset(row + 4 * (cursor - spans[cur][0]), 0, 4 * (spans[cur][1] - cursor));
      if (!row_bytes) row += 4 * (spans[cur][1] - spans[cur][0]);
      if (cur + 1 < r1) {
        cursor = spans[cur + 1][0];
        if (row_bytes) row = row_start(cur + 1);
      }
    }
  };
  // The runs of rows [r0, r1) (sorted by y).
  const int y0 = plan.rect.y + r0, y1 = plan.rect.y + r1;
  const auto first = std::lower_bound(plan.runs.begin(), plan.runs.end(), y0,
                                      [](const Run& run, int y) { return run.y < y; });
  const auto last =
      std::lower_bound(first, plan.runs.end(), y1, [](const Run& run, int y) { return run.y < y; });
  if (first == last) {
    finish_rows_before(r1);
    return;
  }

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
  const bool cubic = plan.sampling == Sampling::kBicubic;
  // The AVX2 bilinear gather reads taps at 32-bit byte offsets (made in the
  // coordinate pass); an image of 2 GiB or more takes the SSE2 kernel, whose
  // bytes are the same.
  const bool wide = kernel == Kernel::kAvx2 || kernel == Kernel::kAvx512;
  if (wide && !cubic &&
      static_cast<double>(image.step[0]) * image.rows > static_cast<double>(INT32_MAX))
    kernel = Kernel::kSse2;

  // The AVX-512 bilinear gather's way of reading taps (tap_loads()).
  const bool hardware_gather =
      kernel == Kernel::kAvx512 && !cubic && tap_loads() == TapLoads::kGather;
  alignas(32) int32_t iu[kBlock], iv[kBlock], wtop[kBlock], wbot[kBlock], off[kBlock];
  for (auto it = first; it != last; ++it) {
    const Run& run = *it;
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
    finish_rows_before(r);
    std::memset(row + 4 * (cursor - spans[r][0]), 0, 4 * (run.x0 - cursor));
    cursor = run.x1;
    for (int x = run.x0; x < run.x1; x += kBlock) {
      const int n = std::min(kBlock, run.x1 - x);
      uint8_t* dst = row + 4 * (x - spans[r][0]);
#ifdef LF_X86_SIMD
      if (kernel == Kernel::kAvx2 || kernel == Kernel::kAvx512) {
        (kernel == Kernel::kAvx512 ? kernels::coords_avx512 : kernels::coords_avx2)(
            distort, cubic, k, x, n, iu, iv, wtop, wbot, stride, cubic ? nullptr : off);
        if (cubic)
          kernels::gather_cubic_avx2(image.data, stride, cam.width, cam.height, n, iu, iv, wtop,
                                     wbot, dst);
        else if (kernel == Kernel::kAvx512)
          kernels::gather_avx512(hardware_gather, image.data, stride, n, off, iu, iv, wtop, wbot,
                                 dst);
        else
          kernels::gather_avx2(image.data, stride, n, off, iu, iv, wtop, wbot, dst);
        continue;
      }
#endif
      const bool sse2 = kernel == Kernel::kSse2;
      if (cubic) {
        // SSE2 has no byte shuffle: its bicubic gather is the reference.
        if (distort)
          coords_sse2<true, true>(sse2, k, x, n, iu, iv, wtop, wbot);
        else
          coords_sse2<false, true>(sse2, k, x, n, iu, iv, wtop, wbot);
        for (int i = 0; i < n; ++i)
          kernels::gather_cubic1(image.data, stride, cam.width, cam.height, iu[i], iv[i], wtop[i],
                                 wbot[i], dst + 4 * i);
        continue;
      }
      if (distort)
        coords_sse2<true, false>(sse2, k, x, n, iu, iv, wtop, wbot);
      else
        coords_sse2<false, false>(sse2, k, x, n, iu, iv, wtop, wbot);
      gather_sse2(sse2, image.data, stride, n, iu, iv, wtop, wbot, dst);
    }
  }
  finish_rows_before(r1);
}

}  // namespace lf
