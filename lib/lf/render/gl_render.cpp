#include "lf/render/gl_render.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <opencv2/core/utility.hpp>
#include <stdexcept>
#include <string>

#include "lf/geometry/projection.h"
#include "lf/render/render.h"
#include "lf/render/render_kernels.h"

#ifdef LF_HAVE_GL
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <glm/glm.hpp>

#include "lf/render/gl_context.h"
#include "lf/render/gl_tables.h"
#endif

namespace lf {

namespace {
bool maybe_hardware_gl();  // below: false when no EGL device can be a GPU
}  // namespace

Backend resolve_backend(Backend asked, std::string* message) {
  if (asked == Backend::kCpu) return Backend::kCpu;
  if (asked == Backend::kAuto && !maybe_hardware_gl()) {
    // Decided without making a context (no GL driver is started in a
    // process that will not use it).
    if (message) *message = "backend auto: CPU (no EGL device is a hardware GPU)";
    return Backend::kCpu;
  }
  const GlInfo& gl = gl_info();
  if (asked == Backend::kGl) {
    if (!gl.available)
      throw std::runtime_error("GL backend asked for but unavailable: " + gl.error);
    return Backend::kGl;
  }
  if (gl.available && !gl.software) {
    if (message) *message = "backend auto: GL on " + gl.renderer;
    return Backend::kGl;
  }
  if (message)
    *message = gl.available ? "backend auto: CPU (GL renderer '" + gl.renderer +
                                  "' is a software rasteriser)"
                            : "backend auto: CPU (no GL: " + gl.error + ")";
  return Backend::kCpu;
}

#ifndef LF_HAVE_GL

namespace {
bool maybe_hardware_gl() {
  return false;
}
}  // namespace

const GlInfo& gl_info() {
  static const GlInfo info = [] {
    GlInfo i;
    i.error = "this build has no EGL/GLES (meson found no egl, glesv2 or glm)";
    return i;
  }();
  return info;
}

struct GlRenderer::Impl {};
GlRenderer::GlRenderer() {
  throw std::runtime_error("GL backend unavailable: " + gl_info().error);
}
GlRenderer::~GlRenderer() = default;
const GlInfo& GlRenderer::info() const {
  return gl_info();
}
void GlRenderer::set_image(int, const cv::Mat&) {}
void GlRenderer::render_pixels(const FragmentPlan&, const Camera&, int, uint8_t*) {}
void GlRenderer::render_fragment(const FragmentPlan&, const Camera&, const cv::Mat&, Fragment&) {}
cv::Mat GlRenderer::render_view(const Rig&, const ViewRequest&, RenderStats*, int) {
  return {};
}
std::vector<std::pair<size_t, std::string>> GlRenderer::composite(
    int, int, const std::vector<FragmentPixels>&, cv::Mat&) {
  return {};
}
std::vector<std::pair<size_t, std::string>> GlRenderer::composite(
    int, int, const std::vector<FragmentPixels>&, const std::vector<PlannedFragment>&, cv::Mat&) {
  return {};
}
cv::Mat GlRenderer::render_view(const Rig&, const std::vector<cv::Mat>&, const ViewRequest&,
                                RenderStats*, int) {
  return {};
}
void GlRenderer::interleave(const DisplayCalibration&, const Quilt&, const cv::Mat&, cv::Mat&) {}

#else

using namespace gl;  // lib/lf/render/gl_context.h

namespace {

bool maybe_hardware_gl() {
  return hardware_gl_possible();
}

double now_ms() {
  using namespace std::chrono;
  return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

// The shaders (lib/lf/render/shaders/*.glsl, compiled in by meson: gl_shaders.h):
// kRunVertex and kRunFragment draw a fragment from its runs, kAddFragment
// adds a received one, kFullVertex covers the target, kInterleaveFragment
// interleaves a quilt, kResolveFragment resolves the sums.
#include "gl_shaders.h"

constexpr int kMaxSlots = 4096;
constexpr int kScratchSlot = -1;

}  // namespace

const GlInfo& gl_info() {
  static const GlInfo info = [] {
    GlInfo i;
    Context c;
    i.error = c.create();
    if (i.error.empty()) {
      Current cur(c);
      i.available = true;
      i.renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
      i.version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
      i.software = software_renderer(i.renderer);
      i.platform = display().platform;
    }
    c.destroy();
    return i;
  }();
  return info;
}

struct GlRenderer::Impl {
  std::mutex mutex;
  Context context;
  GLuint run_program = 0, resolve_program = 0, add_program = 0;
  GLuint interleave_program = 0, quilt_texture = 0;  // made on first use
  GLuint vao = 0;
  GLuint run_table = 0, row_table = 0;     // textures (see kTableWidth)
  GLuint cubic_table = 0;                  // unit 5: kernels::cubic_taps()
  int run_capacity = 0, row_capacity = 0;  // texture rows
  GLuint pixel_table = 0, span_table = 0;  // composite(): pixels and spans
  int pixel_capacity = 0, span_capacity = 0;
  GLenum sum_format = GL_RGBA16F;  // GL_RGBA32F where float blending exists
  GLint add_quad = -1, add_frame = -1, add_rect = -1;
  std::vector<uint32_t> pixel_data;
  std::vector<glm::ivec4> span_data;
  GLuint fbo = 0, target = 0, sum_fbo = 0, sum = 0;
  int target_w = 0, target_h = 0, sum_w = 0, sum_h = 0;
  struct Slot {
    GLuint texture = 0;
    int width = 0, height = 0;
  };
  std::vector<Slot> slots;  // index slot + 1 (0: the scratch slot)
  std::vector<glm::vec4> runs;
  std::vector<glm::ivec2> rows;
  std::vector<uint8_t> readback;
  struct Loc {
    GLint quad, frame, origin, rect, limits, focal, distort, r2max, has_distortion, scale;
  } loc{};

  Slot& slot(int s) {
    if (s < kScratchSlot || s >= kMaxSlots)
      throw std::invalid_argument("GlRenderer: image slot " + std::to_string(s) +
                                  " out of range [0, 4096)");
    if (static_cast<int>(slots.size()) <= s + 1) slots.resize(s + 2);
    return slots[s + 1];
  }

  void upload(int s, const cv::Mat& image) {
    if (image.type() != CV_8UC4 || image.empty())
      throw std::invalid_argument("GlRenderer: image must be 8-bit 4-channel (CV_8UC4)");
    if (image.step[0] % 4 != 0)
      throw std::invalid_argument("GlRenderer: image rows must be a whole number of pixels");
    Slot& sl = slot(s);
    if (!sl.texture) glGenTextures(1, &sl.texture);
    glBindTexture(GL_TEXTURE_2D, sl.texture);
    if (sl.width != image.cols || sl.height != image.rows) {
      glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8UI, image.cols, image.rows, 0, GL_RGBA_INTEGER,
                   GL_UNSIGNED_BYTE, nullptr);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      sl.width = image.cols;
      sl.height = image.rows;
    }
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, static_cast<GLint>(image.step[0] / 4));
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, image.cols, image.rows, GL_RGBA_INTEGER,
                    GL_UNSIGNED_BYTE, image.data);
    glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
    check_gl("image upload");
  }

  // Colour target of at least w x h (grown, never shrunk).
  static void ensure_target(GLuint& fbo, GLuint& tex, int& tw, int& th, int w, int h,
                            GLenum format) {
    if (tw >= w && th >= h && tex) return;
    tw = std::max(tw, w);
    th = std::max(th, h);
    if (!tex) glGenTextures(1, &tex);
    glActiveTexture(GL_TEXTURE0);  // units 1.. hold tables that must stay bound
    glBindTexture(GL_TEXTURE_2D, tex);
    glTexStorage2D(GL_TEXTURE_2D, 1, format, tw, th);  // immutable: a new name each time
    if (!fbo) glGenFramebuffers(1, &fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, tex, 0);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw std::runtime_error("GL: the render target is not renderable on this GL");
  }
  void grow(GLuint& fbo, GLuint& tex, int& tw, int& th, int w, int h, GLenum format) {
    if (tex && (tw < w || th < h)) {
      glDeleteTextures(1, &tex);
      tex = 0;
    }
    ensure_target(fbo, tex, tw, th, w, h, format);
  }

  void set_camera(const Camera& cam, const Slot& sl, float scale) {
    if (sl.width != cam.width || sl.height != cam.height)
      throw std::invalid_argument("GlRenderer: camera " + std::to_string(cam.id) + " is " +
                                  std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                                  " but its image slot holds " + std::to_string(sl.width) + "x" +
                                  std::to_string(sl.height));
    const CameraUniforms u = camera_uniforms(cam);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, sl.texture);
    glUniform4f(loc.limits, u.limits.x, u.limits.y, u.limits.z, u.limits.w);
    glUniform4f(loc.focal, u.focal.x, u.focal.y, u.focal.z, u.focal.w);
    glUniform4f(loc.distort, u.distort.x, u.distort.y, u.distort.z, u.distort.w);
    glUniform1f(loc.r2max, u.r2max);
    glUniform1i(loc.has_distortion, u.has_distortion ? 1 : 0);
    glUniform1f(loc.scale, scale);
  }

  // Uploads `data` (texels of `T`, padded here to whole table rows) into
  // the table texture `tex` on unit `unit`, growing it as needed.
  template <typename T>
  void upload_table(GLuint tex, int unit, std::vector<T>& data, int& capacity, GLenum internal,
                    GLenum format, GLenum type) {
    const int height = std::max<int>(1, (data.size() + kTableWidth - 1) / kTableWidth);
    data.resize(static_cast<size_t>(height) * kTableWidth, T(0));
    glActiveTexture(GL_TEXTURE0 + unit);
    glBindTexture(GL_TEXTURE_2D, tex);
    if (height > capacity) {
      capacity = std::max(height, 2 * capacity);
      glTexImage2D(GL_TEXTURE_2D, 0, internal, kTableWidth, capacity, 0, format, type, nullptr);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    }
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, kTableWidth, height, format, type, data.data());
  }
  // Clears the accumulation target (at least w x h) and sets up additive
  // blending into it.
  void begin_sum(int w, int h) {
    grow(sum_fbo, sum, sum_w, sum_h, w, h, sum_format);
    glBindFramebuffer(GL_FRAMEBUFFER, sum_fbo);
    glViewport(0, 0, sum_w, sum_h);
    glClearColor(0, 0, 0, 0);
    glClear(GL_COLOR_BUFFER_BIT);
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE);
  }
  // The final pass: the sums resolved into an 8-bit w x h target, read
  // back into `out` (CV_8UC4).
  void resolve(int w, int h, cv::Mat& out, RenderStats* stats = nullptr) {
    glDisable(GL_BLEND);
    grow(fbo, target, target_w, target_h, w, h, GL_RGBA8);
    glBindFramebuffer(GL_FRAMEBUFFER, fbo);
    glViewport(0, 0, w, h);
    glUseProgram(resolve_program);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, sum);
    glBindVertexArray(vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    out.create(h, w, CV_8UC4);
    if (!out.isContinuous()) throw std::logic_error("GlRenderer: output not continuous");
    const double t0 = stats ? now_ms() : 0;
    if (stats) glFinish();  // timed apart (the read back waits for it anyway)
    const double t1 = stats ? now_ms() : 0;
    glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, out.data);
    if (stats) stats->gpu_ms = t1 - t0, stats->readback_ms = now_ms() - t1;
  }
  // Uploads the run and row tables built with append_tables().
  void upload_tables() {
    upload_table(run_table, 1, runs, run_capacity, GL_RGBA32F, GL_RGBA, GL_FLOAT);
    upload_table(row_table, 2, rows, row_capacity, GL_RG32I, GL_RG_INTEGER, GL_INT);
    glActiveTexture(GL_TEXTURE0);
  }
  // Draws the rectangle of a plan whose rows start at `first_row` in the
  // row table, with the run program as set up.
  void draw_plan(const FragmentPlan& plan, int first_row) {
    const cv::Rect& rc = plan.rect;
    glUniform4f(loc.quad, static_cast<float>(rc.x), static_cast<float>(rc.y),
                static_cast<float>(rc.x + rc.width), static_cast<float>(rc.y + rc.height));
    glUniform2i(loc.rect, rc.y, first_row);
    glBindVertexArray(vao);
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
  }

  // Draws `planned` into the accumulation target (begin_sum()) from their
  // images, with the run program (scale 1: the sums take whole numbers).
  void draw_planned(const std::vector<PlannedFragment>& planned, RenderStats* stats = nullptr) {
    if (planned.empty()) return;
    const double t0 = now_ms();
    glUseProgram(run_program);
    glUniform4f(loc.frame, 0.0f, 0.0f, static_cast<float>(sum_w), static_cast<float>(sum_h));
    glUniform2i(loc.origin, 0, 0);
    runs.clear();
    rows.clear();
    std::vector<int> first_row;
    first_row.reserve(planned.size());
    for (const PlannedFragment& pf : planned)
      first_row.push_back(pf.plan->runs.empty() ? 0 : append_tables(*pf.plan, runs, rows));
    upload_tables();
    const double t1 = now_ms();
    if (stats) stats->tables_ms = t1 - t0;
    for (size_t k = 0; k < planned.size(); ++k) {
      if (planned[k].plan->runs.empty()) continue;
      set_camera(*planned[k].camera, slot(planned[k].slot), 1.0f);
      draw_plan(*planned[k].plan, first_row[k]);
    }
    if (stats) stats->draw_ms = now_ms() - t1;
  }

  void init() {
    const std::string why = context.create();
    if (!why.empty()) throw std::runtime_error("GL backend unavailable: " + why);
    Current cur(context);
    run_program = link(kRunVertex, kRunFragment);
    resolve_program = link(kFullVertex, kResolveFragment);
    loc.quad = glGetUniformLocation(run_program, "u_quad");
    loc.frame = glGetUniformLocation(run_program, "u_frame");
    loc.origin = glGetUniformLocation(run_program, "u_origin");
    loc.rect = glGetUniformLocation(run_program, "u_rect");
    loc.limits = glGetUniformLocation(run_program, "u_limits");
    loc.focal = glGetUniformLocation(run_program, "u_focal");
    loc.distort = glGetUniformLocation(run_program, "u_distort");
    loc.r2max = glGetUniformLocation(run_program, "u_r2max");
    loc.has_distortion = glGetUniformLocation(run_program, "u_has_distortion");
    loc.scale = glGetUniformLocation(run_program, "u_scale");
    glUseProgram(run_program);
    glUniform1i(glGetUniformLocation(run_program, "u_image"), 0);
    glUniform1i(glGetUniformLocation(run_program, "u_runs"), 1);
    glUniform1i(glGetUniformLocation(run_program, "u_rows"), 2);
    glUniform1i(glGetUniformLocation(run_program, "u_cubic"), 5);
    glUseProgram(resolve_program);
    glUniform1i(glGetUniformLocation(resolve_program, "u_sum"), 0);
    add_program = link(kRunVertex, kAddFragment);
    glUseProgram(add_program);
    glUniform1i(glGetUniformLocation(add_program, "u_pixels"), 3);
    glUniform1i(glGetUniformLocation(add_program, "u_spans"), 4);
    add_quad = glGetUniformLocation(add_program, "u_quad");
    add_frame = glGetUniformLocation(add_program, "u_frame");
    add_rect = glGetUniformLocation(add_program, "u_rect");
    glGenTextures(1, &pixel_table);
    glGenTextures(1, &span_table);
    const char* ext = reinterpret_cast<const char*>(glGetString(GL_EXTENSIONS));
    if (has_word(ext, "GL_EXT_float_blend") && has_word(ext, "GL_EXT_color_buffer_float"))
      sum_format = GL_RGBA32F;
    glGenVertexArrays(1, &vao);  // no attributes: positions come from gl_VertexID
    glGenTextures(1, &run_table);
    glGenTextures(1, &row_table);
    {
      // The bicubic taps, bound to unit 5 for good.
      const int phases = (1 << kernels::kPhaseBits) + 1;
      std::vector<glm::ivec4> taps(phases);
      for (int k = 0; k < phases; ++k) {
        const int16_t* t = kernels::cubic_taps()[k];
        taps[k] = glm::ivec4(t[0], t[1], t[2], t[3]);
      }
      glGenTextures(1, &cubic_table);
      glActiveTexture(GL_TEXTURE5);
      glBindTexture(GL_TEXTURE_2D, cubic_table);
      glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32I, phases, 1, 0, GL_RGBA_INTEGER, GL_INT,
                   taps.data());
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
      glActiveTexture(GL_TEXTURE0);
    }
    glDisable(GL_DITHER);
    glPixelStorei(GL_PACK_ALIGNMENT, 4);
    check_gl("setup");
  }

  void release() {
    if (context.ctx == EGL_NO_CONTEXT) return;
    {
      Current cur(context);
      for (const Slot& s : slots)
        if (s.texture) glDeleteTextures(1, &s.texture);
      const GLuint textures[] = {target,      sum,        run_table,  row_table,
                                 pixel_table, span_table, cubic_table};
      glDeleteTextures(7, textures);
      const GLuint fbos[] = {fbo, sum_fbo};
      glDeleteFramebuffers(2, fbos);
      glDeleteVertexArrays(1, &vao);
      glDeleteProgram(run_program);
      glDeleteProgram(resolve_program);
      glDeleteProgram(add_program);
      if (interleave_program) glDeleteProgram(interleave_program);
      if (quilt_texture) glDeleteTextures(1, &quilt_texture);
    }
    context.destroy();
  }
};

GlRenderer::GlRenderer() : impl_(std::make_unique<Impl>()) {
  try {
    impl_->init();
  } catch (...) {
    impl_->release();
    throw;
  }
}

GlRenderer::~GlRenderer() {
  try {
    impl_->release();
  } catch (const std::exception&) {
    // A context that can no longer be made current leaks its objects with it.
  }
}

const GlInfo& GlRenderer::info() const {
  return gl_info();
}

void GlRenderer::interleave(const DisplayCalibration& cal, const Quilt& layout,
                            const cv::Mat& quilt, cv::Mat& out) {
  if (quilt.type() != CV_8UC4 || quilt.empty())
    throw std::invalid_argument("GlRenderer::interleave: the quilt must be RGBA (CV_8UC4)");
  validate_quilt(layout, quilt.cols, quilt.rows);
  const LenticularConstants k = lenticular_constants(cal);
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Impl& m = *impl_;
  Current cur(m.context);
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  if (quilt.cols > max_size || quilt.rows > max_size)
    throw std::invalid_argument("GlRenderer::interleave: a " + std::to_string(quilt.cols) + "x" +
                                std::to_string(quilt.rows) + " quilt exceeds this GL's " +
                                std::to_string(max_size) + " texels");
  if (!m.interleave_program) {
    m.interleave_program = link(kFullVertex, kInterleaveFragment);
    glUseProgram(m.interleave_program);
    glUniform1i(glGetUniformLocation(m.interleave_program, "u_quilt"), 0);
    glGenTextures(1, &m.quilt_texture);
  }
  // The target first: making it binds it to unit 0.
  m.grow(m.fbo, m.target, m.target_w, m.target_h, cal.screen_w, cal.screen_h, GL_RGBA8);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, m.quilt_texture);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, static_cast<GLint>(quilt.step / 4));
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, quilt.cols, quilt.rows, 0, GL_RGBA, GL_UNSIGNED_BYTE,
               quilt.data);
  glPixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glDisable(GL_BLEND);
  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glViewport(0, 0, cal.screen_w, cal.screen_h);
  glUseProgram(m.interleave_program);
  const GLuint prog = m.interleave_program;
  glUniform4f(glGetUniformLocation(prog, "u_k"), k.pitch, k.tilt, k.subp, k.center);
  glUniform4i(glGetUniformLocation(prog, "u_screen"), cal.screen_w, cal.screen_h,
              cal.flip_image_x ? 1 : 0, cal.inv_view ? 1 : 0);
  glUniform4i(glGetUniformLocation(prog, "u_layout"), layout.views, layout.cols, layout.rows,
              cal.flip_subp ? 1 : 0);
  glBindVertexArray(m.vao);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  out.create(cal.screen_h, cal.screen_w, CV_8UC4);
  if (!out.isContinuous()) throw std::logic_error("GlRenderer: output not continuous");
  glReadPixels(0, 0, cal.screen_w, cal.screen_h, GL_RGBA, GL_UNSIGNED_BYTE, out.data);
  check_gl("interleave");
}

void GlRenderer::set_image(int slot, const cv::Mat& image) {
  if (slot < 0)
    throw std::invalid_argument("GlRenderer: image slot " + std::to_string(slot) +
                                " out of range [0, 4096)");
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Current cur(impl_->context);
  impl_->upload(slot, image);
}

void GlRenderer::render_pixels(const FragmentPlan& plan, const Camera& camera, int slot,
                               uint8_t* pixels) {
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  const auto& spans = plan.row_spans;
  if (plan.runs.empty()) {
    if (plan.pixel_count() > 0) std::memset(pixels, 0, 4 * plan.pixel_count());
    return;
  }
  Current cur(m.context);
  const Impl::Slot& sl = m.slot(slot);
  const cv::Rect& rc = plan.rect;
  m.grow(m.fbo, m.target, m.target_w, m.target_h, rc.width, rc.height, GL_RGBA8);
  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glViewport(0, 0, m.target_w, m.target_h);
  glDisable(GL_BLEND);
  glClearColor(0, 0, 0, 0);
  glClear(GL_COLOR_BUFFER_BIT);
  glUseProgram(m.run_program);
  glUniform4f(m.loc.frame, static_cast<float>(rc.x), static_cast<float>(rc.y),
              static_cast<float>(m.target_w), static_cast<float>(m.target_h));
  glUniform2i(m.loc.origin, rc.x, rc.y);
  m.set_camera(camera, sl, 1.0f / 255.0f);
  m.runs.clear();
  m.rows.clear();
  const int first_row = append_tables(plan, m.runs, m.rows);
  m.upload_tables();
  m.draw_plan(plan, first_row);
  m.readback.resize(static_cast<size_t>(rc.width) * rc.height * 4);
  glReadPixels(0, 0, rc.width, rc.height, GL_RGBA, GL_UNSIGNED_BYTE, m.readback.data());
  check_gl("fragment rendering");
  uint8_t* dst = pixels;
  for (size_t r = 0; r < spans.size(); ++r) {
    const int n = spans[r][1] - spans[r][0];
    std::memcpy(dst, m.readback.data() + (r * rc.width + (spans[r][0] - rc.x)) * 4, 4 * n);
    dst += 4 * n;
  }
}

void GlRenderer::render_fragment(const FragmentPlan& plan, const Camera& camera,
                                 const cv::Mat& image, Fragment& out) {
  describe_fragment(plan, out);
  out.camera_id = static_cast<uint32_t>(camera.id);
  out.pixels.resize(4 * plan.pixel_count());
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    Current cur(impl_->context);
    impl_->upload(kScratchSlot, image);
  }
  render_pixels(plan, camera, kScratchSlot, out.pixels.data());
}

cv::Mat GlRenderer::render_view(const Rig& rig, const std::vector<cv::Mat>& images,
                                const ViewRequest& request, RenderStats* stats, int threads) {
  if (images.size() != rig.cameras.size())
    throw std::invalid_argument("GlRenderer::render_view: " + std::to_string(images.size()) +
                                " images for " + std::to_string(rig.cameras.size()) + " cameras");
  for (size_t i = 0; i < images.size(); ++i) set_image(static_cast<int>(i), images[i]);
  return render_view(rig, request, stats, threads);
}

cv::Mat GlRenderer::render_view(const Rig& rig, const ViewRequest& request, RenderStats* stats,
                                int threads) {
  if (request.surface.two_planes())
    throw std::invalid_argument(
        "GlRenderer::render_view: two planes per tile are composited on the CPU only "
        "(lf::render_view)");
  const double t0 = now_ms();
  const ViewGeometry g(rig, request);
  const int n = static_cast<int>(rig.cameras.size());
  std::vector<FragmentPlan> plans(n);
  auto work = [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) plans[i] = plan_fragment(g, i);
  };
  if (threads > 1) {
    const int old = cv::getNumThreads();
    cv::setNumThreads(threads);
    cv::parallel_for_(cv::Range(0, n), work);
    cv::setNumThreads(old);
  } else {
    work(cv::Range(0, n));
  }
  const double t1 = now_ms();
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  Current cur(m.context);
  const int w = request.view.width, h = request.view.height;
  // Sums of up to a few 8-bit contributions per pixel are whole numbers
  // below 2048: exact in half floats, so the blending adds exactly.
  m.begin_sum(w, h);
  RenderStats s;
  s.plan_ms = t1 - t0;
  std::vector<PlannedFragment> planned;
  for (int i = 0; i < n; ++i) {
    if (plans[i].runs.empty()) continue;
    planned.push_back({&plans[i], &rig.cameras[i], i});
    s.fragment_pixels += plans[i].pixel_count();
    ++s.contributing;
  }
  s.setup_ms = now_ms() - t1;
  m.draw_planned(planned, &s);
  cv::Mat out;
  m.resolve(w, h, out, &s);
  check_gl("view rendering");
  s.render_ms = now_ms() - t1;
  if (stats) *stats = s;
  return out;
}

std::vector<std::pair<size_t, std::string>> GlRenderer::composite(
    int width, int height, const std::vector<FragmentPixels>& fragments, cv::Mat& out) {
  return composite(width, height, fragments, {}, out);
}

std::vector<std::pair<size_t, std::string>> GlRenderer::composite(
    int width, int height, const std::vector<FragmentPixels>& fragments,
    const std::vector<PlannedFragment>& planned, cv::Mat& out) {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    throw std::invalid_argument("compositor: output size out of range");
  const cv::Rect frame(0, 0, width, height);
  for (const PlannedFragment& pf : planned)
    if (!pf.plan || !pf.camera ||
        (!pf.plan->runs.empty() && (pf.plan->rect & frame) != pf.plan->rect))
      throw std::invalid_argument("GlRenderer::composite: a planned fragment outside the frame");
  // lf::Compositor::add()'s checks.
  std::vector<std::pair<size_t, std::string>> refused;
  std::vector<const FragmentPixels*> ok;
  Impl& m = *impl_;
  std::lock_guard<std::mutex> lock(m.mutex);
  m.pixel_data.clear();
  m.span_data.clear();
  std::vector<int> first_row;
  for (size_t i = 0; i < fragments.size(); ++i) {
    const FragmentPixels& fp = fragments[i];
    size_t n = 0;
    try {
      if (!fp.fragment) throw std::invalid_argument("compositor: null fragment");
      n = Compositor::check(*fp.fragment, fp.pixels, width, height);
    } catch (const std::invalid_argument& e) {
      refused.emplace_back(i, e.what());
      continue;
    }
    if (fp.fragment->empty() || n == 0) continue;
    const Fragment& f = *fp.fragment;
    first_row.push_back(static_cast<int>(m.span_data.size()));
    size_t start = m.pixel_data.size();
    for (const auto& sp : f.spans) {
      m.span_data.push_back({static_cast<int>(start), sp[0], sp[1], f.weight_shift});
      start += sp[1] - sp[0];
    }
    const size_t at = m.pixel_data.size();
    m.pixel_data.resize(at + n);
    std::memcpy(m.pixel_data.data() + at, fp.pixels, 4 * n);
    ok.push_back(&fp);
  }
  Current cur(m.context);
  GLint max_size = 0;
  glGetIntegerv(GL_MAX_TEXTURE_SIZE, &max_size);
  if (m.pixel_data.size() > static_cast<size_t>(kTableWidth) * max_size ||
      m.span_data.size() > static_cast<size_t>(kTableWidth) * max_size)
    throw std::invalid_argument("GlRenderer::composite: more fragment pixels than a texture holds");
  m.upload_table(m.pixel_table, 3, m.pixel_data, m.pixel_capacity, GL_RGBA8UI, GL_RGBA_INTEGER,
                 GL_UNSIGNED_BYTE);
  m.upload_table(m.span_table, 4, m.span_data, m.span_capacity, GL_RGBA32I, GL_RGBA_INTEGER,
                 GL_INT);
  glActiveTexture(GL_TEXTURE0);
  m.begin_sum(width, height);
  glUseProgram(m.add_program);
  glUniform4f(m.add_frame, 0.0f, 0.0f, static_cast<float>(m.sum_w), static_cast<float>(m.sum_h));
  glBindVertexArray(m.vao);
  for (size_t k = 0; k < ok.size(); ++k) {
    const cv::Rect& rc = ok[k]->fragment->rect;
    glUniform4f(m.add_quad, static_cast<float>(rc.x), static_cast<float>(rc.y),
                static_cast<float>(rc.x + rc.width), static_cast<float>(rc.y + rc.height));
    glUniform2i(m.add_rect, rc.y, first_row[k]);
    glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
  }
  m.draw_planned(planned);
  m.resolve(width, height, out);
  check_gl("compositing");
  return refused;
}

#endif  // LF_HAVE_GL

}  // namespace lf
