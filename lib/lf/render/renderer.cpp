#include "lf/render/renderer.h"

#include <algorithm>
#include <cstring>
#include <exception>
#include <opencv2/core/utility.hpp>
#include <stdexcept>

#include "lf/render/render.h"

namespace lf {

// The backend names (lf/render/gl_render.h), beside the one place that
// chooses the backend.
const char* backend_name(Backend backend) {
  switch (backend) {
    case Backend::kAuto:
      return "auto";
    case Backend::kCpu:
      return "cpu";
    case Backend::kGl:
      return "gl";
  }
  return "?";
}

bool parse_backend(const std::string& text, Backend* out) {
  for (Backend b : {Backend::kAuto, Backend::kCpu, Backend::kGl})
    if (text == backend_name(b)) {
      *out = b;
      return true;
    }
  return false;
}

void Renderer::check_slot(int slot) {
  if (slot < 0 || slot >= kMaxSlots)
    throw std::invalid_argument("renderer: image slot " + std::to_string(slot) + " not in 0.." +
                                std::to_string(kMaxSlots - 1));
}

std::vector<std::pair<size_t, std::string>> Renderer::composite(
    int eye, int width, int height, const std::vector<FragmentPixels>& fragments,
    const std::vector<SlotDrawing>& drawings, cv::Mat& into) {
  if (eye != 0 && eye != 1) throw std::invalid_argument("renderer: eye must be 0 or 1");
  const bool layered =
      std::any_of(fragments.begin(), fragments.end(),
                  [](const FragmentPixels& f) { return f.fragment && f.fragment->layer != 0; }) ||
      std::any_of(drawings.begin(), drawings.end(),
                  [](const SlotDrawing& d) { return d.plan && d.plan->layer != 0; });
  if (!layered) return add(eye, width, height, fragments, drawings, into);
  // Two planes per tile, chosen per pixel from every camera's pixels. Layer
  // 0's drawings from images in this process's memory (the CPU's) are drawn
  // band by band into the sums (LayerCompositor with drawings); the others
  // (layer 1's, GL's) are drawn first, into fragments of their own.
  std::vector<Fragment>& drawn = drawn_[eye];
  std::vector<Scratch>& scratch = scratch_[eye];
  std::vector<FragmentPixels> all = fragments;
  std::vector<FragmentDrawing> fused;
  std::vector<size_t> fused_index, drawn_index;
  std::vector<SlotDrawing> to_draw;
  for (size_t i = 0; i < drawings.size(); ++i) {
    const SlotDrawing& d = drawings[i];
    if (!d.plan || !d.camera) throw std::invalid_argument("renderer: a drawing without its plan");
    const cv::Mat* image = d.plan->layer == 0 ? cpu_image(d.slot) : nullptr;
    if (image) {
      fused.push_back({d.plan, d.camera, image});
      fused_index.push_back(i);
    } else {
      to_draw.push_back(d);
      drawn_index.push_back(i);
    }
  }
  drawn.resize(to_draw.size());
  scratch.resize(to_draw.size());
  std::vector<uint8_t*> pixels(to_draw.size());
  for (size_t i = 0; i < to_draw.size(); ++i) {
    const SlotDrawing& d = to_draw[i];
    drawn[i] = Fragment{};
    describe_fragment(*d.plan, drawn[i]);
    drawn[i].camera_id = static_cast<uint32_t>(d.camera->id);
    // The last frame's memory when it is large enough; never zeroed (every
    // byte is drawn).
    const size_t bytes = 4 * d.plan->pixel_count();
    if (scratch[i].capacity < bytes)
      scratch[i] = {std::unique_ptr<uint8_t[]>(new uint8_t[bytes]), bytes};
    pixels[i] = scratch[i].bytes.get();
    all.push_back({&drawn[i], pixels[i]});
  }
  draw_all(to_draw, pixels);
  // (index, why) in the caller's numbering: fragments, then drawings.
  std::vector<std::pair<size_t, std::string>> refused =
      layers_[eye].composite(width, height, all, fused, into);
  const size_t nf = fragments.size();
  for (auto& [k, why] : refused)
    k = k < nf ? k : k < all.size() ? nf + drawn_index[k - nf] : nf + fused_index[k - all.size()];
  std::sort(refused.begin(), refused.end());
  return refused;
}

void Renderer::draw_all(const std::vector<SlotDrawing>& drawings,
                        const std::vector<uint8_t*>& pixels) {
  for (size_t i = 0; i < drawings.size(); ++i)
    draw(*drawings[i].plan, *drawings[i].camera, drawings[i].slot, pixels[i]);
}

namespace {

// The CPU kernels (SSE2/AVX2; the reference).
class CpuRenderer final : public Renderer {
 public:
  Backend backend() const override { return Backend::kCpu; }
  void set_image(int slot, const cv::Mat& image, const void*, uint64_t) override {
    check_slot(slot);
    if (image.type() != CV_8UC4) throw std::invalid_argument("renderer: images are CV_8UC4");
    if (images_.size() <= static_cast<size_t>(slot)) images_.resize(slot + 1);
    images_[slot] = image;
  }
  void draw(const FragmentPlan& plan, const Camera& camera, int slot, uint8_t* pixels) override {
    render_pixels(plan, camera, image(slot), pixels);
  }
  void draw_rect(const FragmentPlan& plan, const Camera& camera, int slot, uint8_t* pixels,
                 size_t row_bytes) override {
    render_rows(plan, camera, image(slot), 0, plan.rect.height, pixels, Kernel::kBest, row_bytes);
  }
  void interleave(const DisplayCalibration& cal, const Quilt& layout, const cv::Mat& quilt,
                  cv::Mat& panel) override {
    interleave_quilt(cal, layout, quilt, panel);
  }

 protected:
  const cv::Mat* cpu_image(int slot) const override { return &image(slot); }
  // On every core, each drawing by one thread (the bytes are the serial
  // ones); the first drawing's error in drawing order is thrown, as the
  // serial loop would throw it.
  void draw_all(const std::vector<SlotDrawing>& drawings,
                const std::vector<uint8_t*>& pixels) override {
    std::vector<std::exception_ptr> failed(drawings.size());
    cv::parallel_for_(cv::Range(0, static_cast<int>(drawings.size())), [&](const cv::Range& r) {
      for (int i = r.start; i < r.end; ++i) try {
          const SlotDrawing& d = drawings[i];
          draw(*d.plan, *d.camera, d.slot, pixels[i]);
        } catch (...) {
          failed[i] = std::current_exception();
        }
    });
    for (const std::exception_ptr& e : failed)
      if (e) std::rethrow_exception(e);
  }
  std::vector<std::pair<size_t, std::string>> add(int eye, int width, int height,
                                                  const std::vector<FragmentPixels>& fragments,
                                                  const std::vector<SlotDrawing>& drawings,
                                                  cv::Mat& into) override {
    // Fused: each band of rows draws its part of every drawing straight
    // into its sums, on all cores (Compositor::composite with drawings).
    std::vector<FragmentDrawing> d;
    d.reserve(drawings.size());
    for (const SlotDrawing& s : drawings) d.push_back({s.plan, s.camera, &image(s.slot)});
    return compositors_[eye].composite(width, height, fragments, d, into);
  }

 private:
  const cv::Mat& image(int slot) const {
    check_slot(slot);
    if (static_cast<size_t>(slot) >= images_.size() || images_[slot].empty())
      throw std::invalid_argument("renderer: no image in slot " + std::to_string(slot));
    return images_[slot];
  }
  void release() override {
    Renderer::release();
    for (Compositor& c : compositors_) c.release();
  }
  std::vector<cv::Mat> images_;
  Compositor compositors_[2];
};

// EGL/GLES 3 (lf/render/gl_render.h): each frame uploaded once into its slot.
class GlBackend final : public Renderer {
 public:
  Backend backend() const override { return Backend::kGl; }
  void set_image(int slot, const cv::Mat& image, const void* key, uint64_t pts) override {
    check_slot(slot);
    if (uploaded_.size() <= static_cast<size_t>(slot))
      uploaded_.resize(slot + 1, {nullptr, UINT64_MAX});
    auto& up = uploaded_[slot];
    if (up.first == key && up.second == pts && key) return;
    gl_.set_image(slot, image);
    up = {key, pts};
  }
  void draw(const FragmentPlan& plan, const Camera& camera, int slot, uint8_t* pixels) override {
    gl_.render_pixels(plan, camera, slot, pixels);
  }
  void draw_rect(const FragmentPlan& plan, const Camera& camera, int slot, uint8_t* pixels,
                 size_t row_bytes) override {
    if (row_bytes < 4 * static_cast<size_t>(plan.rect.width))
      throw std::invalid_argument("renderer: row_bytes below the rect's width");
    scratch_.resize(4 * plan.pixel_count());
    gl_.render_pixels(plan, camera, slot, scratch_.data());
    // The spans' pixels, each row's at its place in the rect.
    Fragment head;
    describe_fragment(plan, head);
    const uint8_t* from = scratch_.data();
    for (size_t r = 0; r < head.spans.size(); ++r) {
      const auto& [begin, end] = head.spans[r];
      if (end <= begin) continue;
      const size_t n = 4 * static_cast<size_t>(end - begin);
      std::memcpy(pixels + r * row_bytes + 4 * static_cast<size_t>(begin - plan.rect.x), from, n);
      from += n;
    }
  }
  void interleave(const DisplayCalibration& cal, const Quilt& layout, const cv::Mat& quilt,
                  cv::Mat& panel) override {
    if (panel.isContinuous())
      gl_.interleave(cal, layout, quilt, panel);
    else  // (the shader reads back into one continuous image)
      interleave_quilt(cal, layout, quilt, panel);
  }

 protected:
  std::vector<std::pair<size_t, std::string>> add(int, int width, int height,
                                                  const std::vector<FragmentPixels>& fragments,
                                                  const std::vector<SlotDrawing>& drawings,
                                                  cv::Mat& into) override {
    return gl_.composite(width, height, fragments, drawings, into);
  }

 private:
  GlRenderer gl_;
  std::vector<std::pair<const void*, uint64_t>> uploaded_;  // each slot's frame (key, pts)
  std::vector<uint8_t> scratch_;
};

}  // namespace

std::unique_ptr<Renderer> make_renderer(Backend backend, std::string* why) {
  if (resolve_backend(backend, why) == Backend::kGl) return std::make_unique<GlBackend>();
  return std::make_unique<CpuRenderer>();
}

}  // namespace lf
