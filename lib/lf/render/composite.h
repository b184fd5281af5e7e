// Compositing of fragments into an output frame (Yang et al. 2002, Section
// 4.3). Fragments: lf/render/fragment.h (premultiplied 8-bit pixels in row spans).
#pragma once

#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "lf/geometry/camera.h"
#include "lf/render/fragment.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"

namespace lf {

// A fragment and where its pixels are: its own (f.pixels.data()) or
// borrowed, e.g. from a received buffer (lf/wire/wire.h parse_fragment_in_place).
struct FragmentPixels {
  const Fragment* fragment = nullptr;
  const uint8_t* pixels = nullptr;
};

// A fragment not drawn yet: its plan (lf/render/plan.h), its camera and the
// camera's current image (CV_8UC4, camera.width x camera.height), as
// lf/render/render.h render_pixels() takes them. Compositor::composite draws it
// band by band straight into its sums (no fragment in memory).
struct FragmentDrawing {
  const FragmentPlan* plan = nullptr;
  const Camera* camera = nullptr;
  const cv::Mat* image = nullptr;
};

// Additive compositor with renormalisation (Section 4.3: "It then adds the
// fragment into the frame buffer"). Accumulates premultiplied fragments and
// divides by the accumulated weight, so missing or partially invalid
// fragments do not darken the image.
class Compositor {
 public:
  void reset(int width, int height);
  // The same with only rows [y0, y1) zeroed (0 <= y0 <= y1 <= height): the
  // other rows' sums are left as they were, so only those rows may be added
  // to and read (LayerCompositor: the rows that layer 1 reaches).
  void reset(int width, int height, int y0, int y1);
  // Zeroes the sums in `r` (within the frame of the last reset()), e.g.
  // after reset(width, height, 0, 0): only those pixels may then be added
  // to and read (LayerCompositor: the blocks that layer 1 reaches).
  void zero(const cv::Rect& r);
  // Frees the sums (16 bytes a pixel); the next reset() allocates them again.
  void release() {
    std::vector<uint32_t>().swap(acc_);
    summed_ = false;
  }
  // Adds a fragment. Throws std::invalid_argument if it does not fit the
  // frame, std::logic_error without a reset() since the last composite() or
  // release() (add(), zero(), resolve(), weight_at() and sums_at() alike).
  void add(const Fragment& f);
  // Adds a fragment whose pixels live elsewhere (f.pixels is not read; e.g.
  // lf/wire/wire.h parse_fragment_in_place): `pixels` holds 4 bytes per pixel of
  // f's spans, row after row. Same checks and exceptions.
  void add(const Fragment& f, const uint8_t* pixels);
  // Writes the normalised frame (CV_8UC4; alpha = 255 where any weight arrived,
  // 0 elsewhere, where colour is 0).
  void resolve(cv::Mat& out) const;
  // A whole frame at once, fused: the same as reset(width, height), add() of
  // each fragment in order, then resolve(out), bit for bit, but the frame is
  // cut into bands of 16 rows, and each band's sums are zeroed, accumulated
  // and resolved in a buffer of its thread that stays in cache (16 bytes a
  // pixel: 160 KiB at 640 wide, 480 KiB at 1920), the bands in parallel
  // (cv::parallel_for_; cv::setNumThreads() sets the threads, 1: this thread
  // only). The frame's sums are not kept (unless set_keep_sums(true)): after
  // composite(), reset() comes before add(), zero(), resolve(), weight_at()
  // or sums_at(). A fragment
  // that add() would refuse is left out; returned: (its index, why) for each.
  // Throws std::invalid_argument for a size out of range, as reset() does.
  std::vector<std::pair<size_t, std::string>> composite(
      int width, int height, const std::vector<FragmentPixels>& fragments, cv::Mat& out);
  // The same with fragments still to draw besides (render and composite
  // fused): each band draws the drawings' rows within it
  // (lf/render/render.h render_rows, best kernel) into a buffer of its thread and
  // adds them at once, while the band's sums are in cache. The frame equals,
  // bit for bit, composite() of the fragments followed by the drawings
  // rendered by render_fragment(). A drawing that render_pixels() or add()
  // would refuse (no plan, camera or image, an image of the wrong size or
  // type, a plan for another output size) is left out and returned as
  // (fragments.size() + its index, why). `rows_added`, when given, is
  // called with each fragment's and drawing's rows [r0, r1) of a band right
  // after they were added (`pixels`: row r0's, in the spans' layout), in
  // the order they are added, by the band's thread (bands on other threads
  // at the same time: it may write only within the band's rows).
  // `row_summed`, when given, is called with each row y of the frame and
  // its sums (`sums[4 x + c]`: pixel x's premultiplied colour c, c = 3 its
  // weight) once every fragment and drawing was added to it and
  // `rows_added` called, before the row is resolved, by the band's thread
  // (it may write only within the band's rows): what is read of the sums
  // there comes from cache, not memory.
  using RowsAdded = std::function<void(const Fragment& f, const uint8_t* pixels, int r0, int r1)>;
  using RowSummed = std::function<void(int y, const uint32_t* sums)>;
  std::vector<std::pair<size_t, std::string>> composite(
      int width, int height, const std::vector<FragmentPixels>& fragments,
      const std::vector<FragmentDrawing>& drawings, cv::Mat& out,
      const RowsAdded* rows_added = nullptr, const RowSummed* row_summed = nullptr);
  // true: composite() accumulates in the compositor's frame of sums instead
  // (each band still zeroed, accumulated and resolved by one thread), so
  // that weight_at() and sums_at() read them afterwards; it costs their
  // memory traffic. Default false. Clears set_kept_runs().
  void set_keep_sums(bool keep) { keep_sums_ = keep, kept_runs_ = nullptr; }
  // Keeps only some of the sums: composite() accumulates band by band in
  // its threads' buffers as when it keeps none, and copies into the frame
  // of sums the pixels of (*runs)[i]'s column ranges [x0, x1) in rows
  // [i * run_rows, (i + 1) * run_rows), the only pixels whose weight_at()
  // and sums_at() are then the frame's (the others hold what they held).
  // LayerCompositor keeps layer 0's where layer 1 reaches: the memory
  // traffic of those pixels only. `runs` (at least one entry per run_rows
  // rows, ranges within the frame, else composite() throws
  // std::invalid_argument) is read by composite() and must outlive it;
  // null: none kept. Clears set_keep_sums().
  using Runs = std::vector<std::vector<std::pair<int, int>>>;
  void set_kept_runs(const Runs* runs, int run_rows) {
    kept_runs_ = runs, kept_run_rows_ = run_rows, keep_sums_ = false;
  }
  // Where no weight arrived (alpha 0 in `out`), takes the pixel of
  // `previous` (the last frame shown, same size, CV_8UC4): a frame
  // composited without some of its fragments (a missed deadline) shows the
  // last picture there instead of black. Returns the number of pixels taken.
  // Throws std::invalid_argument if `previous` does not match.
  static size_t fill_from(cv::Mat& out, const cv::Mat& previous);
  // add()'s checks of a fragment for a width x height frame: returns its
  // pixel count; throws std::invalid_argument naming what is wrong (shared
  // with the GL compositor, lf/render/gl_render.h).
  static size_t check(const Fragment& f, const uint8_t* pixels, int width, int height);
  // Accumulated weight (0..255 per full contribution) at a pixel.
  uint32_t weight_at(int x, int y) const { return sums_at(x, y)[3]; }
  // The four accumulated sums (premultiplied colour, weight) of a pixel.
  const uint32_t* sums_at(int x, int y) const {
    require_sums();
    return acc_.data() + (static_cast<size_t>(y) * w_ + x) * 4;
  }
  int width() const { return w_; }
  int height() const { return h_; }
  // The kernel that adds and normalises (lf/render/render.h Kernel; kBest, the
  // default: AVX2 where the CPU has it, else SSE2, else the scalar
  // reference). Every kernel gives the same bytes (tests); throws
  // std::invalid_argument for one this CPU or build lacks. kernel(): the
  // one used.
  void set_kernel(Kernel k);
  Kernel kernel() const;

 private:
  friend class LayerCompositor;  // adds layer 1's rows of blocks on every core (add_rows)
  // Throws std::logic_error unless acc_ holds the sums of reset() and add()
  // (inline: weight_at() and sums_at() are read per pixel).
  void require_sums() const {
    if (!summed_) no_sums();
  }
  [[noreturn]] static void no_sums();
  size_t check(const Fragment& f, const uint8_t* pixels) const {  // its pixel count
    return check(f, pixels, w_, h_);
  }
  // Rows [r0, r1) of a fragment added into, and rows [y0, y1) of the frame
  // resolved from, `sums`: the sums of the frame's rows from sums_y0 on
  // (acc_ and 0, or a band's buffer and its first row).
  void add_rows(const Fragment& f, const uint8_t* pixels, int r0, int r1, uint32_t* sums,
                int sums_y0) const;
  void resolve_rows(cv::Mat& out, int y0, int y1, const uint32_t* sums, int sums_y0) const;
  int w_ = 0, h_ = 0;
  std::vector<uint32_t> acc_;
  bool summed_ = false;  // acc_ holds the w_ x h_ frame of reset() and add()
  bool keep_sums_ = false;
  const Runs* kept_runs_ = nullptr;  // set_kept_runs()
  int kept_run_rows_ = 1;
  Kernel kernel_ = Kernel::kBest;
};

// Partial sums (a camera host adds up its own cameras' fragments before
// sending them; the compositor's renormalisation divides the total colour
// by the total weight, so it stays exact): one fragment holding, per output
// pixel, the sums of the fragments' premultiplied colour and weight. Each
// row's span is the hull of theirs (pixels between two fragments' spans
// are 0, no weight), trimmed to its first and last pixel with a nonzero
// sum, and its rect bounds those spans; `cameras` is the sum of theirs.
// Tags (viewer, sequence, capture time, output size, layer) come from the
// first fragment; camera_id is the first fragment's (the sum's name).
// Empty fragments add cameras only.
// Values: where every sum is within 255, the sums themselves, and
// Compositor gives the same frame bit for bit from the sum as from its
// parts. Sums over 255 by no more than the cameras' rounding (each
// camera's 8-bit weight is off by up to half a level, so weights that add
// up to 1 give up to 255 + cameras / 2) are scaled to 255 at that pixel
// (the ratio, the colour, kept within a level; the weight, against other
// hosts' at the same pixel, within 1 %). Larger sums (a wide aperture)
// take weight_shift s, the least that stores every sum as
// (sum + 2^(s-1)) >> s within that bound (Fragment::weight_shift); each
// level of s loses one bit of the sums (at most 2^(s-1) per value).
// Throws std::invalid_argument for no fragments, fragments of different
// requests, output sizes or layers, a fragment that Compositor::add()
// refuses, or more than kMaxSummedCameras cameras.
Fragment sum_fragments(const std::vector<FragmentPixels>& fragments);

// Two planes per tile (lf/geometry/view.h FocalSurface::second_of: a tile that holds
// two depths, e.g. a thin structure before a background), composited with
// a choice per pixel. Fragments of layer 1 (Fragment::layer) hold each
// camera's pixels in those tiles through the nearer of their two planes,
// layer 0 every tile through its other plane (lf/render/plan.h plan_fragment).
// Each layer is added as by Compositor; where layer 1 has weight, each
// layer also accumulates its cameras' weighted squared colours, so that
// the weighted variance of the cameras' colours (levels^2 summed over the
// three channels) is known there: the photo-consistency of lf/focus/focus.h,
// measured on the fragments, which the compositor receives separately.
// There the output takes the nearer layer, 1, unless layer 0's variance,
// averaged over the kChoiceWindow x kChoiceWindow pixels around it that
// layer 1 covers, is clearly lower: times kChoiceRatio plus kChoiceMargin,
// still below layer 1's: a thin structure before a background is seen
// past by cameras on either side, so both layers can agree there, and
// then the nearer one occludes (docs/rendering.md: 7 x 7 and 1.5 against
// 3 x 3 and 1 gained 0.7-0.8 dB on thin structures, 0.06 dB on Chess). Every other
// pixel is layer 0's, exactly as Compositor's (and without layer-1
// fragments the whole frame is Compositor::composite's, bit for bit).
class LayerCompositor {
 public:
  static constexpr int kChoiceWindow = 7;        // pixels, odd
  static constexpr float kChoiceRatio = 1.5f;    // >= 1
  static constexpr float kChoiceMargin = 64.0f;  // levels^2, 3 channels
  // As Compositor::composite (the same checks, refusals and exceptions,
  // a refusal of a layer other than 0 and 1, and its threads: bands of
  // rows, each pixel's sums in the serial order); `choice`, when given:
  // CV_8UC1, 1 where layer 1 was taken, else 0.
  std::vector<std::pair<size_t, std::string>> composite(
      int width, int height, const std::vector<FragmentPixels>& fragments, cv::Mat& out,
      cv::Mat* choice = nullptr);
  // The same with layer-0 fragments still to draw besides, drawn band by
  // band into layer 0's sums and squares (Compositor::composite with
  // drawings: no fragment in memory): the frame, the choice and the
  // variances equal, bit for bit, composite() of the fragments followed by
  // the drawings rendered by render_fragment(). A drawing that
  // Compositor::composite would refuse, or one of another layer than 0, is
  // left out and returned as (fragments.size() + its index, why).
  std::vector<std::pair<size_t, std::string>> composite(
      int width, int height, const std::vector<FragmentPixels>& fragments,
      const std::vector<FragmentDrawing>& drawings, cv::Mat& out, cv::Mat* choice = nullptr);
  // The last composite's colour variance of a layer (CV_32FC1, levels^2
  // summed over 3 channels) where layer 1 has weight; 0 elsewhere.
  cv::Mat variance(int layer) const;
  // Frees the sums; the next composite() allocates them again.
  void release() {
    for (int l = 0; l < 2; ++l) comp_[l].release(), sq_[l].release();
    var_[0].release(), var_[1].release(), win_.release();
  }

 private:
  Compositor comp_[2];  // comp_[1] and sq_: zeroed (and valid) in the blocks on_ only
  // The last composite's blocks of 8 x 8 pixels that layer 1 reaches, row
  // by row (bcols_ a row), and the rows [y0_, y1_) they span (0, 0: none).
  std::vector<uint8_t> on_;
  int bcols_ = 0, y0_ = 0, y1_ = 0;
  cv::Mat sq_[2];  // CV_32FC1: sum over cameras of w * |c|^2, where layer 1 has weight
  // CV_32FC1, in the blocks on_ only: each layer's variance, computed
  // while its sums and squares are in cache (layer 0's in its composite:
  // Compositor::RowSummed); the choice reads these.
  cv::Mat var_[2];
  // The frame's size (memory kept from frame to frame), CV_32FC3, written
  // and read only in the blocks that the window reaches from layer 1's: the
  // layers' variances where layer 1 has weight (else 0) and a 1 there (else
  // 0), whose window sums the choice takes.
  cv::Mat win_;
};

}  // namespace lf
