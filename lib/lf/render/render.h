// CPU rendering of a planned fragment (Yang et al. 2002, Section 4.2: the
// random access camera warps the part of its image that a view needs).
// Input: a FragmentPlan (lf/render/plan.h) and the camera's current image; output:
// the Fragment's pixels (lf/render/fragment.h gives their layout: 8-bit,
// premultiplied by the aperture weight).
#pragma once

#include <opencv2/core.hpp>

#include "lf/geometry/camera.h"
#include "lf/render/fragment.h"
#include "lf/render/plan.h"

namespace lf {

// Renders a planned fragment from the camera's current image (CV_8UC4,
// camera.width x camera.height). Bilinear sampling (or bicubic, when the
// plan's request asks: Keys a = -0.5, taps clamped to the image) with edge
// clamping within half a pixel of the border; samples outside, behind the camera, or where
// the camera's distortion cannot be evaluated get alpha 0. Lens distortion is
// applied to the sampling coordinates when the camera has any. No threads,
// no allocation beyond `out`'s spans and pixels. Throws std::invalid_argument on an image
// of the wrong size or type.
//
// Kernels: kScalar is the reference; kSse2 (x86-64 baseline), kAvx2 and
// kAvx512 (the coordinate pass 16 pixels wide, the bilinear gather 8, the
// bicubic gather AVX2's;
// each chosen at run time where the CPU has it) evaluate the same
// arithmetic and give bit-identical results (tests/test_render.cpp). kBest is the fastest
// that this CPU and build have (best_kernel()); the meson option simd=false
// leaves only the scalar kernel. Asking for a kernel that is not available
// throws std::invalid_argument.
enum class Kernel { kBest, kScalar, kSse2, kAvx2, kAvx512 };
void render_fragment(const FragmentPlan& plan, const Camera& camera, const cv::Mat& image,
                     Fragment& out, Kernel kernel = Kernel::kBest);

// The same in two steps, for a caller that renders straight into memory of
// its own (a sender's output buffer, lf/wire/wire.h: write_raw_fragment):
// describe_fragment() sets `out`'s camera id, output size, rect and spans
// from the plan and clears its pixels; render_pixels() then writes the
// plan's pixels, 4 * plan.pixel_count() bytes row after row in the spans'
// layout, every byte of them (pixels between a row's runs get 0). Same
// values as render_fragment(); same exceptions.
void describe_fragment(const FragmentPlan& plan, Fragment& out);
void render_pixels(const FragmentPlan& plan, const Camera& camera, const cv::Mat& image,
                   uint8_t* pixels, Kernel kernel = Kernel::kBest);
// Rows [r0, r1) of the plan's rect only (0 <= r0 <= r1 <= its height), as
// render_pixels() writes them: `pixels` receives those rows' span pixels,
// row after row (4 bytes each, the same values). For a caller that renders
// a fragment in pieces, e.g. band by band into its sums
// (lf/render/composite.h Compositor::composite with drawings). With row_bytes > 0
// the rows are laid out as in an image of the rect instead: row r's span
// pixels start at pixels + (r - r0) * row_bytes + 4 * (begin - rect.x)
// (row_bytes >= 4 * rect.width), and the bytes outside the spans are not
// written (e.g. straight into the rectangle a JPEG encoder takes,
// lf/wire/wire.h serialize_jpeg_fragment). Throws std::invalid_argument for rows
// out of range or a row_bytes too small, and as render_pixels().
void render_rows(const FragmentPlan& plan, const Camera& camera, const cv::Mat& image, int r0,
                 int r1, uint8_t* pixels, Kernel kernel = Kernel::kBest, size_t row_bytes = 0);
bool kernel_available(Kernel kernel);
Kernel best_kernel();  // never kBest

// "scalar", "sse2", "avx2", "avx512" (kBest: the one it picks).
const char* kernel_name(Kernel kernel);
bool simd_available();  // kernel_available(Kernel::kSse2)

// How the kAvx512 kernel's bilinear gather reads each pixel's four taps
// (two 8-byte pairs, one a row): kGather by the AVX-512 gather instruction
// (eight pixels' pairs of a row in one), kLoads by scalar 8-byte loads, as
// the AVX2 kernel does. Which is faster depends on the CPU: on a 2-core AMD
// EPYC (Zen 4), whose 512-bit gathers are slow, the loads take 0.66-0.70x
// the gathers' time per 64-camera view, plan included, and put the kernel
// at 0.85-0.92x AVX2's, where the gathers put it at 1.20-1.38x (`lf-bench
// --sizes 640x480 --skip-quality --skip-bandwidth`, three runs); on another
// VM of the same CPU model the gathers made it 0.81x AVX2's, on the Intel
// Xeon of docs/results.md's earlier reports 0.85x. So kAuto (the default)
// times both once, at the first bilinear AVX-512 render of the process, on
// a synthetic warp (under a millisecond: the faster of nine alternating
// trials each), and keeps the faster. The bytes are the same either way
// (tests/test_render.cpp); the bicubic gather is AVX2's either way.
enum class TapLoads { kAuto, kGather, kLoads };
// Process-wide; kAuto goes back to the timed choice. For benchmarks and
// tests; thread-safe, but a render already running keeps the way it began with.
void set_tap_loads(TapLoads t);
// The way in use, never kAuto: the timed choice (timing it first if it was
// not yet) unless set_tap_loads() chose. kLoads where AVX-512 is unavailable.
TapLoads tap_loads();
const char* tap_loads_name(TapLoads t);  // "gather instruction", "scalar loads", "self-timed"

}  // namespace lf
