// One interface to the two renderers of fragments and frames: the CPU
// kernels (lf/render/render.h, lf/render/composite.h, lf/render/lenticular.h) and GLES 3
// (lf/render/gl_render.h). make_renderer() chooses one, once; the elements
// (lffragment, lfcompositor, lflenticular) hold a Renderer and never branch
// on the backend. Both give the same pixels (the GL tests hold them to the
// CPU reference).
//
// Images live in slots (0 <= slot < kMaxSlots): a camera's current frame,
// CV_8UC4 at the camera's size, named by a key and a timestamp so that a
// frame already in its slot is not set again (GL: one upload per frame,
// whatever the requests). The CPU keeps the image's header, not a copy: its
// pixels must stay valid until the last draw or composite that reads the
// slot has returned.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "lf/render/composite.h"
#include "lf/render/gl_render.h"
#include "lf/render/lenticular.h"
#include "lf/render/plan.h"

namespace lf {

// A fragment still to draw from the image in a slot (whole-view mode: the
// compositor draws every camera's fragment of a view): its plan, its
// camera and the slot (lf/render/gl_render.h PlannedFragment).
using SlotDrawing = PlannedFragment;

// A fragment whose drawing its camera host left to the compositor
// (whole-view mode, all in one process): its plan and camera, and the
// camera frame to draw it from, named (frame_key, frame_pts) so that a
// renderer sets each frame into the slot once however many requests use it.
struct DeferredDrawing {
  FragmentPlan plan;  // in output pixels of the view
  Camera camera;      // intrinsics and distortion of the camera drawn
  int slot = 0;       // the camera's index in the rig: its image slot
  cv::Mat image;      // CV_8UC4, the camera's size; valid while this lives
  const void* frame_key = nullptr;
  uint64_t frame_pts = UINT64_MAX;
};

class Renderer {
 public:
  static constexpr int kMaxSlots = 4096;
  virtual ~Renderer() = default;
  virtual Backend backend() const = 0;

  // Slot `slot` holds `image` (CV_8UC4), the frame named (key, pts).
  // Throws std::invalid_argument for a slot out of range or a bad image.
  virtual void set_image(int slot, const cv::Mat& image, const void* key, uint64_t pts) = 0;
  // As render_pixels() (lf/render/render.h): the plan's pixels, 4 *
  // plan.pixel_count() bytes in the spans' layout, from the slot's image.
  virtual void draw(const FragmentPlan& plan, const Camera& camera, int slot, uint8_t* pixels) = 0;
  // The same laid out as an image of the plan's rect, row r at pixels + r *
  // row_bytes (row_bytes >= 4 * rect.width), the bytes outside the spans
  // not written (as render_rows() with row_bytes: straight into what
  // serialize_jpeg_fragment() encodes).
  virtual void draw_rect(const FragmentPlan& plan, const Camera& camera, int slot, uint8_t* pixels,
                         size_t row_bytes) = 0;
  // Eye `eye` (0, or 1 for a stereo pair's right eye: each has sums of its
  // own) of a width x height frame: the fragments and the drawings added
  // and resolved into `into` (CV_8UC4), as Compositor::composite(). A frame
  // with layer-1 fragments or drawings (a focal surface's second planes)
  // takes its two planes per tile per pixel (LayerCompositor, on the CPU
  // for either backend; layer 0's drawings fused into it on the CPU
  // backend, the others drawn first, draw_all()). Returns what
  // was left out, (index, why): fragments first, then drawings.
  std::vector<std::pair<size_t, std::string>> composite(
      int eye, int width, int height, const std::vector<FragmentPixels>& fragments,
      const std::vector<SlotDrawing>& drawings, cv::Mat& into);
  // Frees the memory the frames' sums take (a stream ended); the next
  // composite() allocates it again. The images in the slots stay.
  virtual void release() {
    for (LayerCompositor& l : layers_) l.release();
    for (std::vector<Fragment>& d : drawn_) std::vector<Fragment>().swap(d);
    for (std::vector<Scratch>& d : scratch_) std::vector<Scratch>().swap(d);
  }
  // As interleave_quilt() (lf/render/lenticular.h).
  virtual void interleave(const DisplayCalibration& cal, const Quilt& layout, const cv::Mat& quilt,
                          cv::Mat& panel) = 0;

 protected:
  // composite() of a frame without layer-1 fragments.
  virtual std::vector<std::pair<size_t, std::string>> add(
      int eye, int width, int height, const std::vector<FragmentPixels>& fragments,
      const std::vector<SlotDrawing>& drawings, cv::Mat& into) = 0;
  static void check_slot(int slot);
  // composite()'s drawings of a frame with layer-1 fragments, each into
  // its `pixels` (4 * plan pixel_count() bytes): draw() of each in turn;
  // the CPU's on every core.
  virtual void draw_all(const std::vector<SlotDrawing>& drawings,
                        const std::vector<uint8_t*>& pixels);
  // The image in a slot where it is in this process's memory (the CPU's),
  // for composite() to draw from band by band; null where draws read it
  // elsewhere (GL). Throws as check_slot().
  virtual const cv::Mat* cpu_image(int slot) const {
    check_slot(slot);
    return nullptr;
  }

 private:
  LayerCompositor layers_[2];
  // Per eye: the drawings of a frame with layer-1 fragments, drawn into
  // fragments of their own (their memory kept from frame to frame).
  std::vector<Fragment> drawn_[2];
  struct Scratch {  // a drawn fragment's pixels
    std::unique_ptr<uint8_t[]> bytes;
    size_t capacity = 0;
  };
  std::vector<Scratch> scratch_[2];
};

// The renderer for `backend` (lf/render/gl_render.h resolve_backend: auto is GL on
// a hardware GPU, else the CPU; `why`, when given, says which and why).
// Throws std::runtime_error where GL is asked for and cannot be had.
std::unique_ptr<Renderer> make_renderer(Backend backend, std::string* why = nullptr);

}  // namespace lf
