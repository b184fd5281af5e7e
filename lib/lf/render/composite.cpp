#include "lf/render/composite.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <opencv2/core/utility.hpp>
#include <stdexcept>
#include <string>

#include "lf/render/render.h"

#if defined(__SSE2__) && !defined(LF_NO_SIMD)
#include <immintrin.h>
#define LF_COMPOSITE_SSE2 1
#define LF_AVX2 __attribute__((target("avx2")))
#define LF_AVX512 __attribute__((target("avx512f,avx512dq,avx512bw,avx512vl,avx2")))
#endif

namespace lf {

void Compositor::reset(int width, int height) {
  reset(width, height, 0, height);
}

void Compositor::reset(int width, int height, int y0, int y1) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw std::invalid_argument("compositor: output size out of range");
  if (y0 < 0 || y0 > y1 || y1 > height)
    throw std::invalid_argument("compositor: rows to zero out of range");
  w_ = width;
  h_ = height;
  acc_.resize(static_cast<size_t>(width) * height * 4);
  summed_ = true;
  std::fill(acc_.begin() + static_cast<size_t>(y0) * width * 4,
            acc_.begin() + static_cast<size_t>(y1) * width * 4, 0u);
}

void Compositor::no_sums() {
  throw std::logic_error(
      "compositor: no sums to read or add to: reset() first (composite() "
      "keeps none)");
}

void Compositor::zero(const cv::Rect& r) {
  require_sums();
  if ((r & cv::Rect(0, 0, w_, h_)) != r)
    throw std::invalid_argument("compositor: pixels to zero out of the frame");
  for (int y = r.y; y < r.y + r.height; ++y) {
    auto row = acc_.begin() + (static_cast<size_t>(y) * w_ + r.x) * 4;
    std::fill(row, row + static_cast<size_t>(r.width) * 4, 0u);
  }
}

void Compositor::add(const Fragment& f) {
  require_sums();
  if (f.pixels.size() != 4 * check(f, f.pixels.data()))
    check_fragment(f);  // throws, naming the mismatch
  add_rows(f, f.pixels.data(), 0, f.rect.height, acc_.data(), 0);
}

size_t Compositor::check(const Fragment& f, const uint8_t* pixels, int width, int height) {
  if (f.out_width != width || f.out_height != height)
    throw std::invalid_argument("compositor: fragment from camera " + std::to_string(f.camera_id) +
                                " is for a " + std::to_string(f.out_width) + "x" +
                                std::to_string(f.out_height) + " frame, not " +
                                std::to_string(width) + "x" + std::to_string(height));
  const size_t n = check_fragment_geometry(f);
  if (n > 0 && !pixels)
    throw std::invalid_argument("compositor: fragment from camera " + std::to_string(f.camera_id) +
                                " has no pixels");
  return n;
}

void Compositor::add(const Fragment& f, const uint8_t* pixels) {
  require_sums();
  check(f, pixels);
  add_rows(f, pixels, 0, f.rect.height, acc_.data(), 0);
}

// Rows [r0, r1) of the fragment (relative to its rect); `pixels` points at
// row r0's first pixel.
// Adds n values of a fragment into sums; a partial sum's values are its
// sums >> shift (Fragment::weight_shift).
static inline void accumulate(uint32_t* acc, const uint8_t* px, int n, int shift) {
  if (shift == 0)
    for (int i = 0; i < n; ++i) acc[i] += px[i];
  else
    for (int i = 0; i < n; ++i) acc[i] += static_cast<uint32_t>(px[i]) << shift;
}

#ifdef LF_COMPOSITE_SSE2
// AVX2: eight values a step (widened to 32 bits, shifted, added), the rest
// as accumulate(). The same sums.
LF_AVX2 static void accumulate_avx2(uint32_t* acc, const uint8_t* px, int n, int shift) {
  const __m128i count = _mm_cvtsi32_si128(shift);
  int i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m128i b = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(px + i));
    const __m256i v = _mm256_sll_epi32(_mm256_cvtepu8_epi32(b), count);
    __m256i* a = reinterpret_cast<__m256i*>(acc + i);
    _mm256_storeu_si256(a, _mm256_add_epi32(_mm256_loadu_si256(a), v));
  }
  accumulate(acc + i, px + i, n - i, shift);
}

// AVX2: four pixels a step, with the SSE2 loop's float expressions per
// channel (a division by the weight, a product, + 0.5, min 255,
// truncation): bit-identical to resolve1. Returns the pixels done (a
// multiple of 4).
LF_AVX2 static int resolve_avx2(const uint32_t* a, uint8_t* o, int w) {
  const __m256 c255 = _mm256_set1_ps(255.0f), half = _mm256_set1_ps(0.5f);
  const __m256i order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
  const __m128i alpha = _mm_set1_epi32(static_cast<int>(0xff000000u));
  int x = 0;
  for (; x + 4 <= w; x += 4, a += 16, o += 16) {
    const __m256 s01 = _mm256_cvtepi32_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(a)));
    const __m256 s23 =
        _mm256_cvtepi32_ps(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(a + 8)));
    // Each pixel's weight in all four of its lanes; 255 / 0 where none
    // arrived, masked below.
    const __m256 k01 = _mm256_div_ps(c255, _mm256_shuffle_ps(s01, s01, 0xff));
    const __m256 k23 = _mm256_div_ps(c255, _mm256_shuffle_ps(s23, s23, 0xff));
    const __m256i i01 =
        _mm256_cvttps_epi32(_mm256_min_ps(_mm256_add_ps(_mm256_mul_ps(s01, k01), half), c255));
    const __m256i i23 =
        _mm256_cvttps_epi32(_mm256_min_ps(_mm256_add_ps(_mm256_mul_ps(s23, k23), half), c255));
    // Packing interleaves the pixels as 0 2 | 1 3 per lane; the permute
    // restores 0 1 2 3.
    __m256i p = _mm256_packs_epi32(i01, i23);
    p = _mm256_permutevar8x32_epi32(_mm256_packus_epi16(p, p), order);
    const __m128i none =
        _mm_cmpeq_epi32(_mm_setr_epi32(static_cast<int>(a[3]), static_cast<int>(a[7]),
                                       static_cast<int>(a[11]), static_cast<int>(a[15])),
                        _mm_setzero_si128());
    const __m128i px = _mm_andnot_si128(none, _mm_or_si128(_mm256_castsi256_si128(p), alpha));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(o), px);
  }
  return x;
}

// AVX-512 (lib/meson.build builds without fused multiply-adds): sixteen
// values a step, the rest as accumulate(). The same sums.
LF_AVX512 static void accumulate_avx512(uint32_t* acc, const uint8_t* px, int n, int shift) {
  const __m128i count = _mm_cvtsi32_si128(shift);
  int i = 0;
  for (; i + 16 <= n; i += 16) {
    const __m128i b = _mm_loadu_si128(reinterpret_cast<const __m128i*>(px + i));
    const __m512i v = _mm512_sll_epi32(_mm512_cvtepu8_epi32(b), count);
    _mm512_storeu_si512(acc + i, _mm512_add_epi32(_mm512_loadu_si512(acc + i), v));
  }
  accumulate(acc + i, px + i, n - i, shift);
}

// AVX-512: sixteen pixels a step with one division each (the AVX2 loop
// divides in all four lanes of a pixel): their weights gathered into one
// register, 255 / weight, each quotient spread back over its pixel's four
// lanes; the products, + 0.5, min 255 and truncation as resolve1, so
// bit-identical. Returns the pixels done (a multiple of 16).
LF_AVX512 static int resolve_avx512(const uint32_t* a, uint8_t* o, int w) {
  const __m512 c255 = _mm512_set1_ps(255.0f), half = _mm512_set1_ps(0.5f);
  // Lanes 3, 7, ..., 31 of two registers (the weights of eight pixels).
  const __m512i weights =
      _mm512_setr_epi32(3, 7, 11, 15, 19, 23, 27, 31, 3, 7, 11, 15, 19, 23, 27, 31);
  const __m128i alpha = _mm_set1_epi32(static_cast<int>(0xff000000u));
  int x = 0;
  for (; x + 16 <= w; x += 16, a += 64, o += 64) {
    __m512i s[4];
    for (int j = 0; j < 4; ++j) s[j] = _mm512_loadu_si512(a + 16 * j);
    const __m512i w16 =
        _mm512_mask_mov_epi32(_mm512_permutex2var_epi32(s[0], weights, s[1]), 0xff00,
                              _mm512_permutex2var_epi32(s[2], weights, s[3]));
    const __mmask16 some = _mm512_test_epi32_mask(w16, w16);
    const __m512 k16 = _mm512_div_ps(c255, _mm512_cvtepi32_ps(w16));
    for (int j = 0; j < 4; ++j) {
      const __m512i spread = _mm512_setr_epi32(
          4 * j, 4 * j, 4 * j, 4 * j, 4 * j + 1, 4 * j + 1, 4 * j + 1, 4 * j + 1, 4 * j + 2,
          4 * j + 2, 4 * j + 2, 4 * j + 2, 4 * j + 3, 4 * j + 3, 4 * j + 3, 4 * j + 3);
      const __m512 k = _mm512_permutexvar_ps(spread, k16);
      const __m512i v = _mm512_cvttps_epi32(
          _mm512_min_ps(_mm512_add_ps(_mm512_mul_ps(_mm512_cvtepi32_ps(s[j]), k), half), c255));
      const __m128i px = _mm_or_si128(_mm512_cvtusepi32_epi8(v), alpha);
      _mm_storeu_si128(reinterpret_cast<__m128i*>(o + 16 * j),
                       _mm_maskz_mov_epi32(static_cast<__mmask8>((some >> (4 * j)) & 0xf), px));
    }
  }
  return x;
}
#endif

void Compositor::set_kernel(Kernel k) {
  if (k != Kernel::kBest && !kernel_available(k))
    throw std::invalid_argument(std::string("compositor: the ") + kernel_name(k) +
                                " kernel is not available on this CPU or build");
  kernel_ = k;
}

Kernel Compositor::kernel() const {
  return kernel_ == Kernel::kBest ? best_kernel() : kernel_;
}

void Compositor::add_rows(const Fragment& f, const uint8_t* pixels, int r0, int r1, uint32_t* sums,
                          int sums_y0) const {
  void (*add)(uint32_t*, const uint8_t*, int, int) = accumulate;
#ifdef LF_COMPOSITE_SSE2
  if (kernel() == Kernel::kAvx2) add = accumulate_avx2;
  if (kernel() == Kernel::kAvx512) add = accumulate_avx512;
#endif
  const uint8_t* px = pixels;
  for (int r = r0; r < r1; ++r) {
    const int b = f.spans[r][0], e = f.spans[r][1];
    const int n = 4 * (e - b);
    add(sums + (static_cast<size_t>(f.rect.y + r - sums_y0) * w_ + b) * 4, px, n, f.weight_shift);
    px += n;
  }
}

// One pixel: colour sums times 255 / weight, rounded, alpha 255 (alpha 0 and
// colour 0 where no weight arrived). The reference for the SSE2 loop below,
// which evaluates the same float expressions per channel: bit-identical.
static inline void resolve1(const uint32_t* a, uint8_t* o) {
  if (a[3] == 0) {
    o[0] = o[1] = o[2] = o[3] = 0;
    return;
  }
  const float s = 255.0f / static_cast<float>(a[3]);
  for (int ch = 0; ch < 3; ++ch)
    o[ch] = static_cast<uint8_t>(std::min(255.0f, static_cast<float>(a[ch]) * s + 0.5f));
  o[3] = 255;
}

void Compositor::resolve(cv::Mat& out) const {
  require_sums();
  out.create(h_, w_, CV_8UC4);
  resolve_rows(out, 0, h_, acc_.data(), 0);
}

void Compositor::resolve_rows(cv::Mat& out, int y0, int y1, const uint32_t* sums,
                              int sums_y0) const {
  [[maybe_unused]] const Kernel k = kernel();
  for (int y = y0; y < y1; ++y) {
    const uint32_t* a = sums + static_cast<size_t>(y - sums_y0) * w_ * 4;
    uint8_t* o = out.ptr<uint8_t>(y);
    int x = 0;
#ifdef LF_COMPOSITE_SSE2
    if (k == Kernel::kAvx512) {
      x = resolve_avx512(a, o, w_);
      a += 4 * x, o += 4 * x;
    }
    if (k == Kernel::kAvx2 || k == Kernel::kAvx512) {
      const int more = resolve_avx2(a, o, w_ - x);
      x += more, a += 4 * more, o += 4 * more;
    }
    // A pixel per step: its four sums converted and scaled at once (the
    // weight's own lane is replaced by 255 afterwards).
    const __m128 c255 = _mm_set1_ps(255.0f), half = _mm_set1_ps(0.5f);
    for (; x < w_ && k != Kernel::kScalar; ++x, a += 4, o += 4) {
      if (a[3] == 0) {
        std::memset(o, 0, 4);
        continue;
      }
      const __m128 s = _mm_set1_ps(255.0f / static_cast<float>(a[3]));
      const __m128 v = _mm_add_ps(
          _mm_mul_ps(_mm_cvtepi32_ps(_mm_loadu_si128(reinterpret_cast<const __m128i*>(a))), s),
          half);
      __m128i i = _mm_cvttps_epi32(_mm_min_ps(v, c255));
      i = _mm_packus_epi16(_mm_packs_epi32(i, i), i);
      const uint32_t px = static_cast<uint32_t>(_mm_cvtsi128_si32(i)) | 0xff000000u;
      std::memcpy(o, &px, 4);
    }
#endif
    for (; x < w_; ++x, a += 4, o += 4) resolve1(a, o);
  }
}

namespace {
// Where each row of a fragment's pixels starts (bytes; prefix sums of its
// span lengths, one more entry than rows).
std::vector<size_t> row_starts(const Fragment& f) {
  std::vector<size_t> starts(f.spans.size() + 1, 0);
  for (size_t r = 0; r < f.spans.size(); ++r)
    starts[r + 1] = starts[r] + 4 * static_cast<size_t>(f.spans[r][1] - f.spans[r][0]);
  return starts;
}
}  // namespace

std::vector<std::pair<size_t, std::string>> Compositor::composite(
    int width, int height, const std::vector<FragmentPixels>& fragments, cv::Mat& out) {
  return composite(width, height, fragments, {}, out);
}

std::vector<std::pair<size_t, std::string>> Compositor::composite(
    int width, int height, const std::vector<FragmentPixels>& fragments,
    const std::vector<FragmentDrawing>& drawings, cv::Mat& out, const RowsAdded* rows_added,
    const RowSummed* row_summed) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw std::invalid_argument("compositor: output size out of range");
  w_ = width;
  h_ = height;
  // The sums live band by band in the threads' buffers below, or in acc_
  // (all of them, or the kept runs' copied there).
  if (kept_runs_) {
    if (kept_run_rows_ < 1 ||
        kept_runs_->size() < static_cast<size_t>((height + kept_run_rows_ - 1) / kept_run_rows_))
      throw std::invalid_argument("compositor: kept runs do not cover the frame's rows");
    for (const auto& row : *kept_runs_)
      for (const auto& [x0, x1] : row)
        if (x0 < 0 || x0 > x1 || x1 > width)
          throw std::invalid_argument("compositor: a kept run out of the frame");
  }
  if (keep_sums_ || kept_runs_) acc_.resize(static_cast<size_t>(width) * height * 4);
  summed_ = keep_sums_ || kept_runs_;
  out.create(h_, w_, CV_8UC4);
  // The fragments add() would take, and where each of their rows' pixels
  // start (prefix sums of the span lengths, bytes).
  std::vector<std::pair<size_t, std::string>> refused;
  std::vector<const FragmentPixels*> ok;
  std::vector<std::vector<size_t>> row_start;
  ok.reserve(fragments.size());
  row_start.reserve(fragments.size());
  for (size_t i = 0; i < fragments.size(); ++i) {
    const FragmentPixels& fp = fragments[i];
    try {
      if (!fp.fragment) throw std::invalid_argument("compositor: null fragment");
      check(*fp.fragment, fp.pixels);
    } catch (const std::invalid_argument& e) {
      refused.emplace_back(i, e.what());
      continue;
    }
    if (fp.fragment->empty()) continue;
    ok.push_back(&fp);
    row_start.push_back(row_starts(*fp.fragment));
  }
  // The drawings' fragments (rect and spans, no pixels yet), checked as
  // render_pixels() and add() would check them.
  std::vector<Fragment> drawn;
  std::vector<const FragmentDrawing*> to_draw;
  std::vector<std::vector<size_t>> drawn_start;
  drawn.reserve(drawings.size());
  for (size_t i = 0; i < drawings.size(); ++i) {
    const FragmentDrawing& d = drawings[i];
    Fragment f;
    try {
      if (!d.plan || !d.camera || !d.image)
        throw std::invalid_argument("compositor: drawing without a plan, camera or image");
      describe_fragment(*d.plan, f);
      f.camera_id = static_cast<uint32_t>(d.camera->id);
      uint8_t none = 0;
      render_rows(*d.plan, *d.camera, *d.image, 0, 0, &none);  // its image's checks only
      const size_t n = check(f, &none, width, height);
      if (n == 0) continue;
    } catch (const std::invalid_argument& e) {
      refused.emplace_back(fragments.size() + i, e.what());
      continue;
    }
    drawn.push_back(std::move(f));
    to_draw.push_back(&d);
    drawn_start.push_back(row_starts(drawn.back()));
  }
  // Bands of 16 rows: a 640-pixel band's sums take 160 KiB (L2-sized); a
  // band is zeroed, accumulated (drawings drawn) and resolved by one
  // thread, in fragment order, so every sum is the serial one. The band's
  // sums are a buffer of its thread, reused band after band, so they stay
  // in cache: the frame's sums (4.9 MB at 640x480, 33 MB at 1080p) never
  // go to memory and back: lf-gst-bench's kernel bound (`lf-gst-bench
  // --sizes 1920x1080 --encodings raw`, one core) 0.80-0.86x that of the
  // frame's sums, four alternating pairs (15.5-16.9 against 18.1-20.7 ms a
  // view); at 640x480 no change. (16 rows against 32: 2-5 % more frames a
  // second at 640x480 in lfarray, the threads' shares more even; at 1080p
  // the bound 0.87-0.91x of 32 rows' and 0.97-0.98x of 8 rows', two runs
  // each.)
  constexpr int kBandRows = 16;
  const int bands = (h_ + kBandRows - 1) / kBandRows;
  cv::parallel_for_(cv::Range(0, bands), [&](const cv::Range& range) {
    for (int band = range.start; band < range.end; ++band) {
      const int y0 = band * kBandRows, y1 = std::min(h_, y0 + kBandRows);
      const size_t band_size = static_cast<size_t>(y1 - y0) * w_ * 4;
      // Zero between bands: each band clears the rows it resolved while
      // they are still in L1 (no pass over the band's 160 KiB first).
      thread_local std::vector<uint32_t> band_sums;
      uint32_t* bs;
      if (keep_sums_) {
        bs = acc_.data() + static_cast<size_t>(y0) * w_ * 4;
        std::fill(bs, bs + band_size, 0u);
      } else {
        if (band_sums.size() < band_size) band_sums.resize(band_size, 0u);
        bs = band_sums.data();
      }
      try {
        for (size_t k = 0; k < ok.size(); ++k) {
          const Fragment& f = *ok[k]->fragment;
          const int r0 = std::max(y0, f.rect.y) - f.rect.y;
          const int r1 = std::min(y1, f.rect.y + f.rect.height) - f.rect.y;
          if (r0 >= r1) continue;
          add_rows(f, ok[k]->pixels + row_start[k][r0], r0, r1, bs, y0);
          if (rows_added) (*rows_added)(f, ok[k]->pixels + row_start[k][r0], r0, r1);
        }
        for (size_t k = 0; k < drawn.size(); ++k) {
          const Fragment& f = drawn[k];
          const int r0 = std::max(y0, f.rect.y) - f.rect.y;
          const int r1 = std::min(y1, f.rect.y + f.rect.height) - f.rect.y;
          if (r0 >= r1) continue;
          // This thread's buffer for a band's rows of one drawing (reused).
          thread_local std::vector<uint8_t> rows;
          rows.resize(drawn_start[k][r1] - drawn_start[k][r0]);
          const FragmentDrawing& d = *to_draw[k];
          render_rows(*d.plan, *d.camera, *d.image, r0, r1, rows.data());
          add_rows(f, rows.data(), r0, r1, bs, y0);
          if (rows_added) (*rows_added)(f, rows.data(), r0, r1);
        }
      } catch (...) {
        if (!keep_sums_) std::fill(bs, bs + band_size, 0u);
        throw;
      }
      if (keep_sums_) {
        if (row_summed)
          for (int y = y0; y < y1; ++y) (*row_summed)(y, bs + static_cast<size_t>(y - y0) * w_ * 4);
        resolve_rows(out, y0, y1, bs, y0);
        continue;
      }
      const size_t row_size = static_cast<size_t>(w_) * 4;
      for (int y = y0; y < y1; ++y) {
        uint32_t* row = bs + (y - y0) * row_size;
        if (kept_runs_)
          for (const auto& [x0, x1] : (*kept_runs_)[y / kept_run_rows_])
            std::memcpy(acc_.data() + (static_cast<size_t>(y) * w_ + x0) * 4, row + x0 * 4,
                        static_cast<size_t>(x1 - x0) * 4 * sizeof(uint32_t));
        if (row_summed) (*row_summed)(y, row);
        resolve_rows(out, y, y + 1, bs, y0);
        std::memset(row, 0, row_size * sizeof(uint32_t));
      }
    }
  });
  return refused;
}

size_t Compositor::fill_from(cv::Mat& out, const cv::Mat& previous) {
  if (previous.type() != CV_8UC4 || previous.size() != out.size() || out.type() != CV_8UC4)
    throw std::invalid_argument("compositor: previous frame does not match");
  size_t n = 0;
  for (int y = 0; y < out.rows; ++y) {
    uint8_t* o = out.ptr<uint8_t>(y);
    const uint8_t* p = previous.ptr<uint8_t>(y);
    for (int x = 0; x < out.cols; ++x, o += 4, p += 4)
      if (o[3] == 0 && p[3] != 0) {
        o[0] = p[0], o[1] = p[1], o[2] = p[2], o[3] = p[3];
        ++n;
      }
  }
  return n;
}

namespace {
// Blocks of kBlock x kBlock pixels that layer 1 reaches, so that the rest
// of the frame is skipped (two-plane tiles are few where the scene needs
// few).
constexpr int kBlock = 8;
struct Blocks {
  int cols = 0;
  std::vector<uint8_t> on;
  // Per row of blocks, its runs of blocks on, as pixel columns [x0, x1)
  // (left to right; set by find_runs()).
  std::vector<std::vector<std::pair<int, int>>> runs;
  void find_runs(int width) {
    const int rows = cols ? static_cast<int>(on.size()) / cols : 0;
    runs.assign(rows, {});
    for (int by = 0; by < rows; ++by)
      for (int bx = 0; bx < cols;) {
        if (!on[by * cols + bx]) {
          ++bx;
          continue;
        }
        int end = bx;
        while (end < cols && on[by * cols + end]) ++end;
        runs[by].emplace_back(bx * kBlock, std::min(width, end * kBlock));
        bx = end;
      }
  }
};

// Adds 255 |p|^2 / a (w |c|^2 with w = a / 255 and c = 255 p / a, p
// premultiplied) of a fragment's rows [r0, r1) (`pixels`: row r0's) in
// `blocks` where `where` has weight.
void add_squares(const Fragment& f, const uint8_t* pixels, int r0, int r1, const Compositor& where,
                 const Blocks& blocks, cv::Mat& sq) {
  const uint8_t* px = pixels;
  for (int r = r0; r < r1; ++r) {
    const int b = f.spans[r][0], e = f.spans[r][1], y = f.rect.y + r;
    float* row = sq.ptr<float>(y);
    for (const auto& [x0, x1] : blocks.runs[y / kBlock]) {
      if (x0 >= e) break;
      int k = std::max(b, x0);
      const int end = std::min(e, x1);
#ifdef LF_COMPOSITE_SSE2
      // Four pixels at a time, the same float operations in the same order
      // as below (so the same sums); a pixel left out adds +0.
      const uint32_t* sums = where.sums_at(0, y);
      const __m128i zero = _mm_setzero_si128();
      for (; k + 4 <= end; k += 4) {
        const __m128i q = _mm_loadu_si128(reinterpret_cast<const __m128i*>(px + 4 * (k - b)));
        const __m128i lo = _mm_unpacklo_epi8(q, zero), hi = _mm_unpackhi_epi8(q, zero);
        __m128 c0 = _mm_cvtepi32_ps(_mm_unpacklo_epi16(lo, zero));
        __m128 c1 = _mm_cvtepi32_ps(_mm_unpackhi_epi16(lo, zero));
        __m128 c2 = _mm_cvtepi32_ps(_mm_unpacklo_epi16(hi, zero));
        __m128 c3 = _mm_cvtepi32_ps(_mm_unpackhi_epi16(hi, zero));
        _MM_TRANSPOSE4_PS(c0, c1, c2, c3);  // c0..c3: the four pixels' p0, p1, p2, alpha
        const __m128 sq =
            _mm_add_ps(_mm_add_ps(_mm_mul_ps(c0, c0), _mm_mul_ps(c1, c1)), _mm_mul_ps(c2, c2));
        const __m128 add = _mm_div_ps(_mm_mul_ps(_mm_set1_ps(255.0f), sq), c3);
        // The weights in `where`: lane 3 of each pixel's sums.
        const __m128i* w = reinterpret_cast<const __m128i*>(sums + 4 * static_cast<size_t>(k));
        const __m128i w01 = _mm_unpackhi_epi32(_mm_loadu_si128(w), _mm_loadu_si128(w + 1));
        const __m128i w23 = _mm_unpackhi_epi32(_mm_loadu_si128(w + 2), _mm_loadu_si128(w + 3));
        const __m128i weight = _mm_unpackhi_epi64(w01, w23);
        const __m128 skip = _mm_or_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(weight, zero)),
                                      _mm_cmpeq_ps(c3, _mm_setzero_ps()));
        _mm_storeu_ps(row + k, _mm_add_ps(_mm_loadu_ps(row + k), _mm_andnot_ps(skip, add)));
      }
#endif
      for (; k < end; ++k) {
        const uint8_t* q = px + 4 * (k - b);
        if (q[3] == 0 || where.weight_at(k, y) == 0) continue;
        const float p0 = q[0], p1 = q[1], p2 = q[2];
        row[k] += 255.0f * (p0 * p0 + p1 * p1 + p2 * p2) / q[3];
      }
    }
    px += 4 * (e - b);
  }
}

// The colour variance of pixels [0, n) of a row from their sums
// (Compositor::sums_at: premultiplied colour, weight) and sums of squares
// (add_squares): (sum w |c|^2 - |sum w c|^2 / W) / W with W = sum a / 255,
// 0 where the weight is 0 (LayerCompositor::variance).
void row_variances(const uint32_t* sums, const float* sq, int n, float* out) {
  int x = 0;
#ifdef LF_COMPOSITE_SSE2
  // Four pixels at a time, the same float operations in the same order as
  // below (so the same variances).
  for (; x + 4 <= n; x += 4) {
    const __m128i* a = reinterpret_cast<const __m128i*>(sums + 4 * static_cast<size_t>(x));
    __m128 s0 = _mm_cvtepi32_ps(_mm_loadu_si128(a)), s1 = _mm_cvtepi32_ps(_mm_loadu_si128(a + 1));
    __m128 s2 = _mm_cvtepi32_ps(_mm_loadu_si128(a + 2)),
           s3 = _mm_cvtepi32_ps(_mm_loadu_si128(a + 3));
    _MM_TRANSPOSE4_PS(s0, s1, s2, s3);  // s0..s2: the four pixels' colour sums, s3 their weights
    const __m128 W = _mm_div_ps(s3, _mm_set1_ps(255.0f));
    const __m128 m0 = _mm_div_ps(s0, W), m1 = _mm_div_ps(s1, W), m2 = _mm_div_ps(s2, W);
    const __m128 mean2 =
        _mm_add_ps(_mm_add_ps(_mm_mul_ps(m0, m0), _mm_mul_ps(m1, m1)), _mm_mul_ps(m2, m2));
    // max(x, 0): 0 for a NaN (an empty pixel's 0 / 0) as std::max(0, x).
    const __m128 v =
        _mm_max_ps(_mm_sub_ps(_mm_div_ps(_mm_loadu_ps(sq + x), W), mean2), _mm_setzero_ps());
    _mm_storeu_ps(out + x, _mm_andnot_ps(_mm_cmpeq_ps(s3, _mm_setzero_ps()), v));
  }
#endif
  for (; x < n; ++x) {
    const uint32_t* a = sums + 4 * static_cast<size_t>(x);
    if (a[3] == 0) {
      out[x] = 0;
      continue;
    }
    const float W = a[3] / 255.0f;
    const float m0 = a[0] / W, m1 = a[1] / W, m2 = a[2] / W;  // the mean colour
    out[x] = std::max(0.0f, sq[x] / W - (m0 * m0 + m1 * m1 + m2 * m2));
  }
}
}  // namespace

Fragment sum_fragments(const std::vector<FragmentPixels>& fragments) {
  if (fragments.empty()) throw std::invalid_argument("sum_fragments: no fragments");
  const Fragment* first = fragments[0].fragment;
  if (!first) throw std::invalid_argument("sum_fragments: null fragment");
  Fragment out;
  out.viewer_id = first->viewer_id, out.sequence = first->sequence;
  out.camera_id = first->camera_id, out.capture_time_ns = first->capture_time_ns;
  out.layer = first->layer;
  out.out_width = first->out_width, out.out_height = first->out_height;
  size_t cameras = 0;
  cv::Rect rect;
  for (const FragmentPixels& fp : fragments) {
    if (!fp.fragment) throw std::invalid_argument("sum_fragments: null fragment");
    const Fragment& f = *fp.fragment;
    Compositor::check(f, fp.pixels, out.out_width, out.out_height);
    if (f.viewer_id != out.viewer_id || f.sequence != out.sequence || f.layer != out.layer)
      throw std::invalid_argument("sum_fragments: camera " + std::to_string(f.camera_id) +
                                  "'s fragment is of another request or layer");
    cameras += f.cameras;
    if (!f.empty()) rect = rect.area() ? (rect | f.rect) : f.rect;
  }
  if (cameras > static_cast<size_t>(kMaxSummedCameras))
    throw std::invalid_argument("sum_fragments: more than " + std::to_string(kMaxSummedCameras) +
                                " cameras");
  out.cameras = static_cast<uint16_t>(cameras);
  if (rect.area() == 0) return out;
  // Each row's hull of the spans, then the sums in a rect-sized buffer.
  out.rect = rect;
  out.spans.assign(rect.height,
                   {static_cast<uint16_t>(rect.x + rect.width), static_cast<uint16_t>(rect.x)});
  for (const FragmentPixels& fp : fragments) {
    const Fragment& f = *fp.fragment;
    for (int r = 0; r < f.rect.height; ++r) {
      const auto& s = f.spans[r];
      if (s[0] == s[1]) continue;
      auto& o = out.spans[f.rect.y - rect.y + r];
      o[0] = std::min(o[0], s[0]), o[1] = std::max(o[1], s[1]);
    }
  }
  std::vector<size_t> row_start(rect.height + 1, 0);
  for (int r = 0; r < rect.height; ++r) {
    auto& o = out.spans[r];
    if (o[0] > o[1]) o = {o[1], o[1]};  // a row no fragment covers
    row_start[r + 1] = row_start[r] + 4 * (o[1] - o[0]);
  }
  // Kept between calls: a fresh buffer of a frame's sums is page faults
  // of several MB each time (most of the time on a virtual machine).
  thread_local std::vector<uint32_t> acc;
  acc.assign(row_start.back(), 0);
  for (const FragmentPixels& fp : fragments) {
    const Fragment& f = *fp.fragment;
    const uint8_t* px = fp.pixels;
    for (int r = 0; r < f.rect.height; ++r) {
      const auto& s = f.spans[r];
      const int n = 4 * (s[1] - s[0]);
      const int orow = f.rect.y - rect.y + r;
      accumulate(acc.data() + row_start[orow] + 4 * (s[0] - out.spans[orow][0]), px, n,
                 f.weight_shift);
      px += n;
    }
  }
  // Pixels where every sum is 0 (gaps between the fragments' spans, and
  // their own pixels of weight 0, e.g. beyond a camera's image) add
  // nothing: each row's span is trimmed to its first and last pixel with
  // a sum, and the rect to the rows and columns left (the weight's JPEG
  // then sees no step down to 0 inside the spans, and can go at half
  // resolution, lf/wire/wire.h).
  {
    auto zero = [&](int r, int x) {
      const uint32_t* a = acc.data() + row_start[r] + 4 * (x - out.spans[r][0]);
      return (a[0] | a[1] | a[2] | a[3]) == 0;
    };
    int r0 = rect.height, r1 = -1, x0 = rect.x + rect.width, x1 = rect.x;
    std::vector<std::array<uint16_t, 2>> trimmed(rect.height);
    for (int r = 0; r < rect.height; ++r) {
      int b = out.spans[r][0], e = out.spans[r][1];
      while (b < e && zero(r, b)) ++b;
      while (e > b && zero(r, e - 1)) --e;
      trimmed[r] = {static_cast<uint16_t>(b), static_cast<uint16_t>(e)};
      if (b < e) r0 = std::min(r0, r), r1 = r, x0 = std::min(x0, b), x1 = std::max(x1, e);
    }
    if (r1 < 0) {  // nothing but zeros: an empty sum
      out.rect = cv::Rect();
      out.spans.clear();
      return out;
    }
    // Where each kept row's sums start in acc.
    std::vector<std::array<uint16_t, 2>> spans;
    std::vector<size_t> starts;
    for (int r = r0; r <= r1; ++r) {
      auto t = trimmed[r];
      if (t[0] >= t[1]) t = {static_cast<uint16_t>(x0), static_cast<uint16_t>(x0)};
      starts.push_back(row_start[r] + 4 * (t[0] - out.spans[r][0]));
      spans.push_back(t);
    }
    out.rect = cv::Rect(x0, rect.y + r0, x1 - x0, r1 - r0 + 1);
    out.spans = std::move(spans);
    row_start = std::move(starts);
  }
  // The shift: sums over 255 by no more than the cameras' rounding (each
  // camera's 8-bit weight is off by up to half a level: weights that add
  // up to 1 give 255 + cameras / 2 at most) need none; those pixels are
  // scaled to 255 instead, their colour-to-weight ratios kept.
  const uint32_t top = acc.empty() ? 0 : *std::max_element(acc.begin(), acc.end());
  const uint32_t slack = static_cast<uint32_t>(cameras) / 2;
  auto shifted = [](uint32_t v, int s) { return (v + ((1u << s) >> 1)) >> s; };
  int shift = 0;
  while (shift < kMaxWeightShift && shifted(top, shift) > 255 + slack) ++shift;
  if (shifted(top, shift) > 255 + slack)
    throw std::invalid_argument("sum_fragments: sums over 255 << " +
                                std::to_string(kMaxWeightShift));
  out.weight_shift = static_cast<uint8_t>(shift);
  size_t n = 0;
  for (const auto& sp : out.spans) n += sp[1] - sp[0];
  out.pixels.resize(4 * n);
  uint8_t* o = out.pixels.data();
  for (size_t r = 0; r < out.spans.size(); ++r) {
    const uint32_t* a = acc.data() + row_start[r];
    for (int x = out.spans[r][0]; x < out.spans[r][1]; ++x, a += 4, o += 4) {
      uint32_t v[4], m = 0;
      for (int k = 0; k < 4; ++k) v[k] = shifted(a[k], shift), m = std::max(m, v[k]);
      if (m > 255)
        for (int k = 0; k < 4; ++k) v[k] = (v[k] * 255 + m / 2) / m;
      for (int k = 0; k < 4; ++k) o[k] = static_cast<uint8_t>(v[k]);
    }
  }
  return out;
}

std::vector<std::pair<size_t, std::string>> LayerCompositor::composite(
    int width, int height, const std::vector<FragmentPixels>& fragments, cv::Mat& out,
    cv::Mat* choice) {
  return composite(width, height, fragments, {}, out, choice);
}

std::vector<std::pair<size_t, std::string>> LayerCompositor::composite(
    int width, int height, const std::vector<FragmentPixels>& fragments,
    const std::vector<FragmentDrawing>& drawings, cv::Mat& out, cv::Mat* choice) {
  comp_[1].reset(width, height, 0, 0);  // throws for a bad size (layer 0: composite() below)
  y0_ = y1_ = 0;
  std::vector<std::pair<size_t, std::string>> refused;
  std::vector<size_t> layer_of[2];
  for (size_t i = 0; i < fragments.size(); ++i) {
    const FragmentPixels& fp = fragments[i];
    try {
      if (!fp.fragment) throw std::invalid_argument("compositor: null fragment");
      Compositor::check(*fp.fragment, fp.pixels, width, height);
      if (fp.fragment->layer > 1)
        throw std::invalid_argument("compositor: fragment from camera " +
                                    std::to_string(fp.fragment->camera_id) + " is of layer " +
                                    std::to_string(fp.fragment->layer));
    } catch (const std::invalid_argument& e) {
      refused.emplace_back(i, e.what());
      continue;
    }
    layer_of[fp.fragment->layer].push_back(i);
  }
  if (choice) *choice = cv::Mat::zeros(height, width, CV_8UC1);
  // Layer 1's sums and both layers' squares are read only in the blocks
  // that layer 1 reaches, within rows [y0_, y1_).
  y0_ = height, y1_ = 0;
  for (size_t i : layer_of[1]) {
    const cv::Rect& r = fragments[i].fragment->rect;
    if (r.height > 0) y0_ = std::min(y0_, r.y), y1_ = std::max(y1_, r.y + r.height);
  }
  const bool two = y0_ < y1_;
  if (!two) y0_ = y1_ = 0;
  // Layer 1 first: where it has weight is where the choice is made.
  Blocks blocks;
  blocks.cols = (width + kBlock - 1) / kBlock;
  blocks.on.assign(two ? static_cast<size_t>(blocks.cols) * ((height + kBlock - 1) / kBlock) : 0,
                   0);
  if (two) {
    y0_ = y0_ / kBlock * kBlock, y1_ = std::min(height, (y1_ + kBlock - 1) / kBlock * kBlock);
    for (size_t i : layer_of[1]) {
      const Fragment& f = *fragments[i].fragment;
      for (int r = 0; r < f.rect.height; ++r)
        for (int x = f.spans[r][0]; x < f.spans[r][1]; x = (x / kBlock + 1) * kBlock)
          blocks.on[((f.rect.y + r) / kBlock) * blocks.cols + x / kBlock] = 1;
    }
    // Only those blocks are zeroed (each run of them along a row of blocks
    // at once), read and written: a few where the scene needs few.
    blocks.find_runs(width);
    comp_[1].reset(width, height, 0, 0);
    for (int l = 0; l < 2; ++l) {  // the last frame's memory when the size is the same
      sq_[l].create(height, width, CV_32FC1);
      var_[l].create(height, width, CV_32FC1);
    }
    // Each row of blocks by one thread, rows of blocks on every core: its
    // runs zeroed, then layer 1's rows within it added, fragment by
    // fragment, and their squares (layer 1's pixels lie in its blocks: a
    // thread writes its own rows only), then its variances, while the
    // row of blocks is in cache. A pixel's squares are added in the
    // fragments' order; where a fragment has weight, its own rows just
    // added give layer 1 weight (add_squares' test of `where`).
    std::vector<std::vector<size_t>> start1;
    for (size_t i : layer_of[1]) start1.push_back(row_starts(*fragments[i].fragment));
    cv::parallel_for_(cv::Range(0, static_cast<int>(blocks.runs.size())), [&](const cv::Range& r) {
      for (int by = r.start; by < r.end; ++by) {
        const int y0 = by * kBlock, y1 = std::min(height, y0 + kBlock);
        for (const auto& [x0, x1] : blocks.runs[by]) {
          const cv::Rect run(x0, y0, x1 - x0, y1 - y0);
          comp_[1].zero(run);
          for (int l = 0; l < 2; ++l) sq_[l](run).setTo(0);
        }
        if (blocks.runs[by].empty()) continue;
        for (size_t k = 0; k < layer_of[1].size(); ++k) {
          const FragmentPixels& fp = fragments[layer_of[1][k]];
          const Fragment& f = *fp.fragment;
          const int r0 = std::max(y0, f.rect.y) - f.rect.y;
          const int r1 = std::min(y1, f.rect.y + f.rect.height) - f.rect.y;
          if (r0 >= r1) continue;
          const uint8_t* px = fp.pixels + start1[k][r0];
          comp_[1].add_rows(f, px, r0, r1, comp_[1].acc_.data(), 0);
          add_squares(f, px, r0, r1, comp_[1], blocks, sq_[1]);
        }
        for (int y = y0; y < y1; ++y)
          for (const auto& [x0, x1] : blocks.runs[by])
            row_variances(comp_[1].sums_at(x0, y), sq_[1].ptr<float>(y) + x0, x1 - x0,
                          var_[1].ptr<float>(y) + x0);
      }
    });
  }
  on_ = blocks.on, bcols_ = blocks.cols;
  // Layer 0, the whole frame: Compositor's fused, banded composite on every
  // core (its sums are the serial ones, and stay for sums_at), its drawings
  // drawn band by band; each band's rows add their squares where layer 1
  // has weight as they are added (a band's rows are its thread's alone, and
  // each pixel's squares are added in the serial order).
  std::vector<FragmentPixels> zero;
  zero.reserve(layer_of[0].size());
  for (size_t i : layer_of[0]) zero.push_back(fragments[i]);
  std::vector<FragmentDrawing> draw0;
  std::vector<size_t> draw0_index;
  for (size_t i = 0; i < drawings.size(); ++i) {
    if (drawings[i].plan && drawings[i].plan->layer != 0) {
      refused.emplace_back(fragments.size() + i, "compositor: drawing of layer " +
                                                     std::to_string(drawings[i].plan->layer) +
                                                     " (only layer 0 is drawn here)");
      continue;
    }
    draw0.push_back(drawings[i]);
    draw0_index.push_back(i);
  }
  const Compositor::RowsAdded squares = [&](const Fragment& f, const uint8_t* pixels, int r0,
                                            int r1) {
    const int from = std::max(r0, y0_ - f.rect.y), to = std::min(r1, y1_ - f.rect.y);
    if (from >= to) return;
    for (int r = r0; r < from; ++r) pixels += 4 * (f.spans[r][1] - f.spans[r][0]);
    add_squares(f, pixels, from, to, comp_[1], blocks, sq_[0]);
  };
  // Layer 0's variance in layer 1's blocks, from each row's sums and
  // squares as soon as they are complete (in cache: read again from memory
  // in the window's pass below, they took most of its time).
  const Compositor::RowSummed variance0 = [&](int y, const uint32_t* sums) {
    if (y < y0_ || y >= y1_) return;
    for (const auto& [x0, x1] : blocks.runs[y / kBlock])
      row_variances(sums + 4 * static_cast<size_t>(x0), sq_[0].ptr<float>(y) + x0, x1 - x0,
                    var_[0].ptr<float>(y) + x0);
  };
  // The choice reads layer 0's sums where layer 1 reaches only.
  comp_[0].set_kept_runs(two ? &blocks.runs : nullptr, kBlock);
  for (const auto& [k, why] : comp_[0].composite(
           width, height, zero, draw0, out, two ? &squares : nullptr, two ? &variance0 : nullptr))
    refused.emplace_back(
        k < zero.size() ? layer_of[0][k] : fragments.size() + draw0_index[k - zero.size()], why);
  if (!two) return refused;
  // Per pixel where layer 1 has weight: both layers' variances (0
  // elsewhere), and a 1 there, in the blocks the window reaches from layer
  // 1's (R < kBlock: its blocks and their eight neighbours); then, at
  // layer 1's pixels, their sums over the window (zero beyond the frame)
  // give the means over the window's layer-1 pixels. The rest of the frame
  // is neither written nor read.
  const int bcols = blocks.cols, brows = (height + kBlock - 1) / kBlock;
  static_assert(kChoiceWindow / 2 < kBlock, "the window reaches the neighbouring blocks only");
  std::vector<uint8_t> near(blocks.on.size(), 0);
  for (int by = 0; by < brows; ++by)
    for (int bx = 0; bx < bcols; ++bx)
      if (blocks.on[by * bcols + bx])
        for (int j = std::max(0, by - 1); j <= std::min(brows - 1, by + 1); ++j)
          for (int i = std::max(0, bx - 1); i <= std::min(bcols - 1, bx + 1); ++i)
            near[j * bcols + i] = 1;
  win_.create(height, width, CV_32FC3);  // the last frame's memory when the size is the same
  cv::parallel_for_(cv::Range(0, brows), [&](const cv::Range& rows) {
    for (int by = rows.start; by < rows.end; ++by)
      for (int bx = 0; bx < bcols; ++bx) {
        if (!near[by * bcols + bx]) continue;
        const bool in = blocks.on[by * bcols + bx] != 0;
        const int x0 = bx * kBlock, n = std::min(width, x0 + kBlock) - x0;
        for (int y = by * kBlock; y < std::min(height, (by + 1) * kBlock); ++y) {
          // The variances, read where `in` only.
          const float* v0 = var_[0].ptr<float>(y) + x0;
          const float* v1 = var_[1].ptr<float>(y) + x0;
          float* p = win_.ptr<float>(y) + 3 * x0;
          for (int i = 0; i < n; ++i, p += 3) {
            const bool on = in && comp_[1].weight_at(x0 + i, y) > 0;
            p[0] = on ? v0[i] : 0.0f;
            p[1] = on ? v1[i] : 0.0f;
            p[2] = on ? 1.0f : 0.0f;
          }
        }
      }
  });
  // Layer 1's blocks on every core, each block's window sums separably
  // (columns, then rows): each pixel's result is its own.
  const int R = kChoiceWindow / 2;
  cv::parallel_for_(cv::Range(0, brows), [&](const cv::Range& rows) {
    cv::Vec3f col[kBlock][kBlock + 2 * R];  // a block's rows, summed over the window's rows
    for (int by = rows.start; by < rows.end; ++by)
      for (int bx = 0; bx < bcols; ++bx) {
        if (!blocks.on[by * bcols + bx]) continue;
        const int x0 = bx * kBlock, y0 = by * kBlock;
        const int x1 = std::min(width, x0 + kBlock), y1 = std::min(height, y0 + kBlock);
        const int cx0 = std::max(0, x0 - R), cx1 = std::min(width, x1 + R);
        // Running sums down each column and along each row (as box
        // filters keep them).
        for (int x = cx0; x < cx1; ++x) {
          cv::Vec3f c(0, 0, 0);
          for (int j = std::max(0, y0 - R); j < std::min(height, y0 + R); ++j)
            c += win_.at<cv::Vec3f>(j, x);
          for (int y = y0; y < y1; ++y) {
            if (y + R < height) c += win_.at<cv::Vec3f>(y + R, x);
            if (y > y0 && y - R - 1 >= 0) c -= win_.at<cv::Vec3f>(y - R - 1, x);
            col[y - y0][x - cx0] = c;
          }
        }
        for (int y = y0; y < y1; ++y) {
          cv::Vec3f w(0, 0, 0);
          for (int i = std::max(cx0, x0 - R); i < std::min(cx1, x0 + R); ++i)
            w += col[y - y0][i - cx0];
          for (int x = x0; x < x1; ++x) {
            if (x + R < cx1) w += col[y - y0][x + R - cx0];
            if (x > x0 && x - R - 1 >= cx0) w -= col[y - y0][x - R - 1 - cx0];
            if (comp_[1].weight_at(x, y) == 0) continue;
            const float c = std::max(1.0f, w[2]);
            const float s0 = w[0] / c, s1 = w[1] / c;
            // The nearer layer, unless the other agrees clearly better.
            if (kChoiceRatio * s0 + kChoiceMargin < s1 && comp_[0].weight_at(x, y) > 0) continue;
            resolve1(comp_[1].sums_at(x, y), out.ptr<uint8_t>(y) + 4 * x);
            if (choice) choice->at<uint8_t>(y, x) = 1;
          }
        }
      }
  });
  return refused;
}

cv::Mat LayerCompositor::variance(int layer) const {
  const int w = comp_[0].width(), h = comp_[0].height();
  cv::Mat v(h, w, CV_32FC1, cv::Scalar(0));
  std::vector<float> row(w);
  for (int y = y0_; y < y1_; ++y) {
    // As the choice computes them (row_variances, four at a time).
    for (int x0 = 0; x0 < w; x0 += kBlock)
      if (on_[(y / kBlock) * bcols_ + x0 / kBlock])
        row_variances(comp_[layer].sums_at(x0, y), sq_[layer].ptr<float>(y) + x0,
                      std::min(w, x0 + kBlock) - x0, row.data() + x0);
    for (int x = 0; x < w; ++x)
      if (on_[(y / kBlock) * bcols_ + x / kBlock] && comp_[1].weight_at(x, y) > 0)
        v.at<float>(y, x) = row[x];
  }
  return v;
}

}  // namespace lf
