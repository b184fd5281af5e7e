// GPU rendering through EGL and OpenGL ES 3: the paper's own path (Yang et
// al. 2002, Section 4.2.2: fragments rendered by projective texture mapping
// with the aperture weight, then added by the compositor's blending), beside
// the CPU kernels (lf/render/render.h, lf/render/composite.h), which stay the reference.
//
// Context. A headless EGL context, no window system: the EGL device platform
// (EGL_EXT_platform_device; preferring a device that is not software), else
// Mesa's surfaceless platform (EGL_MESA_platform_surfaceless: llvmpipe runs
// anywhere), else eglGetDisplay(EGL_DEFAULT_DISPLAY), which is also used when
// the environment sets EGL_PLATFORM (so EGL_PLATFORM=surfaceless, or a
// platform that does not exist, is honoured). Each GlRenderer owns its own
// context and makes it current only for the length of a call, under a mutex:
// any thread may call it, one at a time.
//
// Arithmetic. The fragment shader evaluates the scalar kernel's expressions
// (lf/render/render_kernels.h: per-run homography rows in float, the aperture
// weight, the radial distortion, the 14-bit fixed-point bilinear weights)
// and gathers the four taps exactly (integer texels, texelFetch), so it
// differs from the CPU only where the GPU's float division or fused
// multiply-adds round differently: at most a few LSB at a few pixels
// (tests/test_gl.cpp measures it). Coverage is the plan's runs, drawn as
// pixel-aligned rectangles: the same pixel set, except that a pixel whose
// source position lies within float rounding of the camera image's border
// may get alpha 0 on one side and not on the other.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "lf/geometry/camera.h"
#include "lf/geometry/rig.h"
#include "lf/geometry/view.h"
#include "lf/render/composite.h"
#include "lf/render/fragment.h"
#include "lf/render/lenticular.h"
#include "lf/render/plan.h"
#include "lf/render/render_view.h"

namespace lf {

// Which renderer draws fragments and composites them.
//  * kCpu: lf/render/render.h and lf/render/composite.h;
//  * kGl: GlRenderer (fails clearly where no GL context can be made);
//  * kAuto: kGl only where a hardware GPU is present (not llvmpipe,
//    softpipe, swrast or another software rasteriser), else kCpu.
enum class Backend { kAuto, kCpu, kGl };
const char* backend_name(Backend backend);  // "auto", "cpu", "gl"
// "auto", "cpu" or "gl" (case-sensitive); false for anything else.
bool parse_backend(const std::string& text, Backend* out);

// What this process's EGL/GLES offers, probed once (the first call makes
// and drops a context; later calls return the same answer).
struct GlInfo {
  bool available = false;  // a GLES >= 3.0 context could be made
  bool software = false;   // its renderer is a software rasteriser
  std::string renderer;    // GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string version;     // GL_VERSION
  std::string platform;    // "device", "surfaceless" or "default" (EGL display used)
  std::string error;       // why not, when !available
};
const GlInfo& gl_info();

// The backend to use for `asked`: kAuto resolves to kGl or kCpu (and
// `message`, when given, says which and why: a line for an info log);
// kCpu stays kCpu; kGl stays kGl when available, else throws
// std::runtime_error("GL backend asked for but unavailable: <why>").
Backend resolve_backend(Backend asked, std::string* message = nullptr);

// A fragment to be drawn from its camera's image into a composite
// (GlRenderer::composite): its plan (lf/render/plan.h, in output pixels), its
// camera (intrinsics, distortion) and the image slot holding the camera's
// frame (GlRenderer::set_image). Not owned.
struct PlannedFragment {
  const FragmentPlan* plan = nullptr;
  const Camera* camera = nullptr;
  int slot = 0;
};

// A GLES 3 renderer of fragments and whole views.
//
// Images: set_image(slot, image) uploads a camera's current frame
// (CV_8UC4, any row stride) into texture `slot` (>= 0; usually the camera's
// index in the rig); it stays there until replaced, so a frame is uploaded
// once however many views or fragments sample it.
class GlRenderer {
 public:
  // Makes the context and compiles the shaders. Throws std::runtime_error
  // with the reason when no GLES 3 context can be made (gl_info().error).
  GlRenderer();
  ~GlRenderer();
  GlRenderer(const GlRenderer&) = delete;
  GlRenderer& operator=(const GlRenderer&) = delete;

  const GlInfo& info() const;

  // Uploads camera image `image` (CV_8UC4) into texture slot `slot`
  // (0 <= slot < 4096). Throws std::invalid_argument on a bad image or slot.
  void set_image(int slot, const cv::Mat& image);

  // As lf::render_pixels(): writes the plan's pixels (4 * plan.pixel_count()
  // bytes, row after row in the spans' layout, premultiplied; 0 between
  // runs) sampling the image in `slot`, which must have the camera's size.
  // Throws std::invalid_argument on a slot without a matching image.
  void render_pixels(const FragmentPlan& plan, const Camera& camera, int slot, uint8_t* pixels);
  // As lf::render_fragment(): uploads `image` into a scratch slot and
  // renders the fragment into `out`.
  void render_fragment(const FragmentPlan& plan, const Camera& camera, const cv::Mat& image,
                       Fragment& out);

  // Whole-view mode (one machine): plans every camera's fragment (CPU,
  // `threads` as lf::render_view), draws all of them into one accumulation
  // target with additive blending (no per-camera readback) and resolves it
  // as lf::Compositor::resolve() does, in a final pass. Uses the images
  // uploaded in slots 0..n-1 (set_image) for the rig's n cameras. Returns
  // CV_8UC4, the request's size. `stats` as lf::render_view (render_ms:
  // drawing and readback; composite_ms: 0, the resolve is part of it).
  // Throws std::invalid_argument for a surface with two planes in some
  // tiles (their per-pixel choice, lf/render/composite.h LayerCompositor, is CPU
  // only).
  cv::Mat render_view(const Rig& rig, const ViewRequest& request, RenderStats* stats = nullptr,
                      int threads = 1);
  // As lf::Compositor::composite() (lf/render/composite.h): adds the fragments
  // (premultiplied pixels wherever they live) by blending in a float target,
  // in a rectangle per fragment, and resolves in a final pass; returns the
  // fragments that lf::Compositor::add() would refuse, (index, why), and
  // leaves them out. Throws std::invalid_argument for a size out of range
  // (1..16384) or more fragment pixels than one texture holds (4096 x the
  // GL's largest texture size: 67 M pixels on llvmpipe).
  std::vector<std::pair<size_t, std::string>> composite(
      int width, int height, const std::vector<FragmentPixels>& fragments, cv::Mat& out);
  // The same, with `planned` fragments drawn here, into the same sums, from
  // their cameras' images (whole-view mode of a pipeline on one machine:
  // lffragment leaves the drawing to lfcompositor, no fragment is read
  // back). Each must lie inside width x height (std::invalid_argument
  // otherwise; empty plans are skipped) and sample a slot holding an image
  // of its camera's size (set_image). The sums equal those of render_pixels() + composite() for
  // the same plans, exactly: the fragment pixels are the same whole numbers.
  std::vector<std::pair<size_t, std::string>> composite(
      int width, int height, const std::vector<FragmentPixels>& fragments,
      const std::vector<PlannedFragment>& planned, cv::Mat& out);

  // The same after uploading images[i] into slot i.
  cv::Mat render_view(const Rig& rig, const std::vector<cv::Mat>& images,
                      const ViewRequest& request, RenderStats* stats = nullptr, int threads = 1);

  // As lf::interleave_quilt() (lf/render/lenticular.h), as a fragment shader: the
  // same single-precision expressions and nearest texel (texelFetch), so
  // the panel differs from the CPU's only at sub-pixels within float
  // rounding of a view boundary (fused multiply-adds), by one view.
  void interleave(const DisplayCalibration& cal, const Quilt& layout, const cv::Mat& quilt,
                  cv::Mat& out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lf
