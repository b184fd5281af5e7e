#include "lf/composite.h"

#include <algorithm>
#include <cstring>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#if defined(__SSE2__) && !defined(LF_NO_SIMD)
#include <emmintrin.h>
#define LF_COMPOSITE_SSE2 1
#endif

namespace lf {

void Compositor::reset(int width, int height) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw std::invalid_argument("compositor: output size out of range");
  w_ = width;
  h_ = height;
  acc_.assign(static_cast<size_t>(width) * height * 4, 0);
}

void Compositor::add(const Fragment& f) {
  if (f.pixels.size() != 4 * check(f, f.pixels.data()))
    check_fragment(f);  // throws, naming the mismatch
  add_rows(f, f.pixels.data(), 0, f.rect.height);
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
  check(f, pixels);
  add_rows(f, pixels, 0, f.rect.height);
}

// Rows [r0, r1) of the fragment (relative to its rect); `pixels` points at
// row r0's first pixel.
void Compositor::add_rows(const Fragment& f, const uint8_t* pixels, int r0, int r1) {
  const uint8_t* px = pixels;
  for (int r = r0; r < r1; ++r) {
    const int b = f.spans[r][0], e = f.spans[r][1];
    uint32_t* acc = acc_.data() + (static_cast<size_t>(f.rect.y + r) * w_ + b) * 4;
    const int n = 4 * (e - b);
    for (int i = 0; i < n; ++i) acc[i] += px[i];
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
  out.create(h_, w_, CV_8UC4);
  resolve_rows(out, 0, h_);
}

void Compositor::resolve_rows(cv::Mat& out, int y0, int y1) const {
  for (int y = y0; y < y1; ++y) {
    const uint32_t* a = acc_.data() + static_cast<size_t>(y) * w_ * 4;
    uint8_t* o = out.ptr<uint8_t>(y);
    int x = 0;
#ifdef LF_COMPOSITE_SSE2
    // A pixel per step: its four sums converted and scaled at once (the
    // weight's own lane is replaced by 255 afterwards).
    const __m128 c255 = _mm_set1_ps(255.0f), half = _mm_set1_ps(0.5f);
    for (; x < w_; ++x, a += 4, o += 4) {
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

std::vector<std::pair<size_t, std::string>> Compositor::composite(
    int width, int height, const std::vector<FragmentPixels>& fragments, cv::Mat& out) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw std::invalid_argument("compositor: output size out of range");
  w_ = width;
  h_ = height;
  acc_.resize(static_cast<size_t>(width) * height * 4);  // zeroed band by band below
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
    const Fragment& f = *fp.fragment;
    std::vector<size_t> starts(f.spans.size() + 1, 0);
    for (size_t r = 0; r < f.spans.size(); ++r)
      starts[r + 1] = starts[r] + 4 * static_cast<size_t>(f.spans[r][1] - f.spans[r][0]);
    ok.push_back(&fp);
    row_start.push_back(std::move(starts));
  }
  // Bands of 32 rows: a 640-pixel band's sums take 320 KiB (L2-sized); a
  // band is zeroed, accumulated and resolved by one thread, in fragment
  // order, so every sum is the serial one.
  constexpr int kBandRows = 32;
  const int bands = (h_ + kBandRows - 1) / kBandRows;
  cv::parallel_for_(cv::Range(0, bands), [&](const cv::Range& range) {
    for (int band = range.start; band < range.end; ++band) {
      const int y0 = band * kBandRows, y1 = std::min(h_, y0 + kBandRows);
      std::fill(acc_.begin() + static_cast<size_t>(y0) * w_ * 4,
                acc_.begin() + static_cast<size_t>(y1) * w_ * 4, 0u);
      for (size_t k = 0; k < ok.size(); ++k) {
        const Fragment& f = *ok[k]->fragment;
        const int r0 = std::max(y0, f.rect.y) - f.rect.y;
        const int r1 = std::min(y1, f.rect.y + f.rect.height) - f.rect.y;
        if (r0 < r1) add_rows(f, ok[k]->pixels + row_start[k][r0], r0, r1);
      }
      resolve_rows(out, y0, y1);
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

void LayerCompositor::reset(int width, int height, int tile, std::vector<uint8_t> nearer) {
  for (int l = 0; l < 2; ++l) comp_[l].reset(width, height);
  if (!nearer.empty() &&
      (tile < 1 || nearer.size() != static_cast<size_t>((width + tile - 1) / tile) *
                                        ((height + tile - 1) / tile)))
    throw std::invalid_argument("compositor: " + std::to_string(nearer.size()) +
                                " nearer-layer entries do not fit the tiles");
  for (int l = 0; l < 2; ++l) sq_[l] = cv::Mat::zeros(height, width, CV_32FC1);
  tile_ = tile;
  nearer_ = std::move(nearer);
}

void LayerCompositor::add(int layer, const Fragment& f) {
  if (f.pixels.size() !=
      4 * Compositor::check(f, f.pixels.data(), comp_[0].width(), comp_[0].height()))
    check_fragment(f);  // throws, naming the mismatch
  add(layer, f, f.pixels.data());
}

void LayerCompositor::add(int layer, const Fragment& f, const uint8_t* pixels) {
  if (layer != 0 && layer != 1)
    throw std::invalid_argument("compositor: layer " + std::to_string(layer) + " is not 0 or 1");
  comp_[layer].add(f, pixels);  // checks
  // w |c|^2 with w = a / 255 and c = 255 p / a (premultiplied p): 255 |p|^2 / a.
  const uint8_t* px = pixels;
  for (int r = 0; r < f.rect.height; ++r) {
    const int b = f.spans[r][0], e = f.spans[r][1];
    float* sq = sq_[layer].ptr<float>(f.rect.y + r);
    for (int x = b; x < e; ++x, px += 4) {
      if (px[3] == 0) continue;
      const float p0 = px[0], p1 = px[1], p2 = px[2];
      sq[x] += 255.0f * (p0 * p0 + p1 * p1 + p2 * p2) / px[3];
    }
  }
}

cv::Mat LayerCompositor::variance(int layer) const {
  const Compositor& c = comp_[layer];
  cv::Mat v(c.height(), c.width(), CV_32FC1);
  for (int y = 0; y < c.height(); ++y) {
    const float* sq = sq_[layer].ptr<float>(y);
    float* o = v.ptr<float>(y);
    for (int x = 0; x < c.width(); ++x) {
      const uint32_t* a = c.sums_at(x, y);
      if (a[3] == 0) {
        o[x] = 0;
        continue;
      }
      // (sum w |c|^2 - |sum w c|^2 / W) / W with W = sum a / 255.
      const float W = a[3] / 255.0f;
      const float m0 = a[0] / W, m1 = a[1] / W, m2 = a[2] / W;  // the mean colour
      o[x] = std::max(0.0f, sq[x] / W - (m0 * m0 + m1 * m1 + m2 * m2));
    }
  }
  return v;
}

void LayerCompositor::resolve(cv::Mat& out, cv::Mat* choice) const {
  comp_[0].resolve(out);
  const int w = comp_[0].width(), h = comp_[0].height();
  cv::Mat covered(h, w, CV_32FC1, cv::Scalar(0));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) covered.at<float>(y, x) = comp_[1].weight_at(x, y) > 0 ? 1.f : 0.f;
  if (choice) *choice = cv::Mat::zeros(h, w, CV_8UC1);
  if (cv::countNonZero(covered) == 0) return;
  // Window sums over layer 1's pixels: both layers' variances, and the count.
  const cv::Size win(kChoiceWindow, kChoiceWindow);
  cv::Mat v0, v1, count;
  cv::boxFilter(variance(0).mul(covered), v0, -1, win, {-1, -1}, false, cv::BORDER_CONSTANT);
  cv::boxFilter(variance(1).mul(covered), v1, -1, win, {-1, -1}, false, cv::BORDER_CONSTANT);
  cv::boxFilter(covered, count, -1, win, {-1, -1}, false, cv::BORDER_CONSTANT);
  cv::max(count, 1.0f, count);
  cv::divide(v0, count, v0);  // window means
  cv::divide(v1, count, v1);
  cv::Mat one;
  comp_[1].resolve(one);
  const int cols = tile_ > 0 ? (w + tile_ - 1) / tile_ : 0;
  for (int y = 0; y < h; ++y) {
    const float* c = covered.ptr<float>(y);
    const float *a = v0.ptr<float>(y), *b = v1.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      if (c[x] == 0) continue;
      const bool near1 = !nearer_.empty() && nearer_[(y / tile_) * cols + x / tile_] == 1;
      // The nearer layer, unless the other agrees clearly better.
      const bool take1 = near1 ? !(a[x] + kChoiceMargin < b[x]) : b[x] + kChoiceMargin < a[x];
      if (!take1 && comp_[0].weight_at(x, y) > 0) continue;
      out.at<cv::Vec4b>(y, x) = one.at<cv::Vec4b>(y, x);
      if (choice) choice->at<uint8_t>(y, x) = 1;
    }
  }
}

}  // namespace lf
