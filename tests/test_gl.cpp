// The EGL/GLES 3 backend (lf/render/gl_render.h) against the CPU reference
// (lf/render/render.h, lf/render/composite.h): fragments for random views and the hard
// cases, lens distortion included, and whole views; backend selection; and
// (suite GlAbsent, run by meson with EGL_PLATFORM pointing nowhere) the
// fallback where no GL context can be made.
//
// Tolerances (issue 13): over the pixels both renderers cover, the mean
// absolute difference per channel <= 1 LSB and the largest <= 3 LSB; the
// covered pixel sets equal, except pixels on the border of a coverage
// region (a pixel with an 8-neighbour of the other state in the CPU
// result), where float rounding may put a source position either side of
// the camera image's edge; those are also at most 0.2 % of the pixels.
// Since both evaluate the same expressions, at most 1 % of the pixels may
// differ at all (on Mesa's llvmpipe none do: the output is bit-identical).
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <random>
#include <string>

#include "helpers.h"
#include "lf/quality/synthetic.h"
#include "lf/render/composite.h"
#include "lf/render/gl_render.h"
#include "lf/render/lenticular.h"
#include "lf/render/plan.h"
#include "lf/render/render.h"
#include "lf/render/render_view.h"
#include "lf/render/renderer.h"

namespace {

constexpr double kDepth = 10.0;

struct Diff {
  size_t both = 0;                 // pixels covered by both
  size_t mismatch = 0;             // covered by one only
  size_t mismatch_off_border = 0;  // of those, not on a coverage border
  size_t differ = 0;               // pixels covered by both that differ at all
  double sum_abs = 0;              // over channels of pixels covered by both
  size_t over3 = 0;                // pixels covered by both that differ by more than 3
  int max_abs = 0;
  void add(const Diff& o) {
    both += o.both;
    over3 += o.over3;
    mismatch += o.mismatch;
    mismatch_off_border += o.mismatch_off_border;
    differ += o.differ;
    sum_abs += o.sum_abs;
    max_abs = std::max(max_abs, o.max_abs);
  }
  double mean() const { return both ? sum_abs / (4.0 * both) : 0.0; }
};

// Compares two CV_8UC4 images; a pixel is covered where its alpha (channel
// 3) is nonzero.
Diff compare(const cv::Mat& cpu, const cv::Mat& gl) {
  Diff d;
  auto covered = [&](int x, int y) { return cpu.at<cv::Vec4b>(y, x)[3] != 0; };
  for (int y = 0; y < cpu.rows; ++y)
    for (int x = 0; x < cpu.cols; ++x) {
      const cv::Vec4b a = cpu.at<cv::Vec4b>(y, x), b = gl.at<cv::Vec4b>(y, x);
      if ((a[3] != 0) != (b[3] != 0)) {
        ++d.mismatch;
        bool border = false;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int nx = x + dx, ny = y + dy;
            if (nx < 0 || ny < 0 || nx >= cpu.cols || ny >= cpu.rows ||
                covered(nx, ny) != covered(x, y))
              border = true;
          }
        if (!border) ++d.mismatch_off_border;
        continue;
      }
      if (a[3] == 0) continue;
      ++d.both;
      d.differ += a != b;
      int most = 0;
      for (int c = 0; c < 4; ++c) {
        const int e = std::abs(a[c] - b[c]);
        d.sum_abs += e;
        most = std::max(most, e);
      }
      d.max_abs = std::max(d.max_abs, most);
      d.over3 += most > 3;
    }
  return d;
}

// A fragment's pixels as an image of its rect (0 outside its spans).
cv::Mat as_image(const lf::Fragment& f) {
  cv::Mat m(std::max(f.rect.height, 1), std::max(f.rect.width, 1), CV_8UC4, cv::Scalar::all(0));
  const uint8_t* p = f.pixels.data();
  for (size_t r = 0; r < f.spans.size(); ++r) {
    const int n = f.spans[r][1] - f.spans[r][0];
    std::memcpy(m.ptr<uint8_t>(static_cast<int>(r)) + 4 * (f.spans[r][0] - f.rect.x), p, 4 * n);
    p += 4 * n;
  }
  return m;
}

// At most 3 LSB apart. A hardware GPU's division is not IEEE's (GLSL ES
// allows 2.5 ULP; the CPU's is correctly rounded): an aperture weight can
// come out one step (1/16384) apart, which moves a premultiplied value by
// one unit, and the resolve divides it by the pixel's summed weight, so
// where that sum is small (a view's edge, one camera's tail) a pixel can
// differ by more. On the NVIDIA H200 (docs/results.md) the whole views
// differed by at most 8 at a few pixels, mean 0.003-0.005 LSB. So on
// hardware: such pixels are the rare exception (1 in 1000), and rounding
// flips at most 2 % of the pixels; a software rasteriser (IEEE) keeps the
// strict bounds.
void expect_max3(const Diff& d, const std::string& what) {
  if (lf::gl_info().software)
    EXPECT_LE(d.max_abs, 3) << what;
  else
    EXPECT_LE(d.over3, d.both / 1000 + 2) << what << " (max " << d.max_abs << ")";
}

void expect_close(const Diff& d, const std::string& what, size_t min_pixels) {
  EXPECT_GE(d.both, min_pixels) << what;
  EXPECT_LE(d.mean(), 1.0) << what;
  expect_max3(d, what);
  EXPECT_EQ(d.mismatch_off_border, 0u) << what;
  EXPECT_LE(d.mismatch, d.both / 500 + 2) << what;
  // The same arithmetic: differences are the exception (float rounding at
  // a tap's weight), not a bias over the image.
  EXPECT_LE(d.differ, d.both / (lf::gl_info().software ? 100 : 50)) << what;
}

std::vector<cv::Mat> images_of(const lf::Rig& rig, double period = 0.7) {
  std::vector<cv::Mat> im;
  for (const auto& c : rig.cameras) im.push_back(lf::render_textured_plane(c, kDepth, period));
  return im;
}

using testing_lf::plane_z;

lf::ViewRequest request(const cv::Vec3d& eye, const cv::Vec3d& target, double vfov,
                        const lf::FocalPlane& plane, int w = 160, int h = 120) {
  return testing_lf::look_request(eye, target, vfov, plane, w, h);
}

// Random views of a 4x4 rig (centred on the origin, spacing 1), and the hard cases of
// tests/test_hard_cases.
std::vector<std::pair<std::string, lf::ViewRequest>> views() {
  std::vector<std::pair<std::string, lf::ViewRequest>> v;
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 6; ++i) {
    const cv::Vec3d eye(1.5 * u(rng), 1.5 * u(rng), -1.0 + 0.8 * u(rng));
    const cv::Vec3d target(2 * u(rng), 2 * u(rng), kDepth);
    const lf::FocalPlane p =
        lf::FocalPlane::through({0, 0, kDepth * (1.0 + 0.4 * u(rng))},
                                cv::normalize(cv::Vec3d(0.2 * u(rng), 0.2 * u(rng), 1)));
    v.emplace_back("random view " + std::to_string(i),
                   request(eye, target, 30 + 20 * (1 + u(rng)), p));
  }
  v.emplace_back("eye on the camera plane",
                 request({-0.3, 0.2, 0.0}, {0.0, 0.0, 10}, 50, plane_z(10)));
  v.emplace_back("eye on the focal plane",
                 request({0.2, 0.4, -1.0}, {0, 0, 10}, 50, plane_z(-1.0)));
  v.emplace_back("focal plane parallel to the rays",
                 request({0.25, 0.1, -1}, {0.25, 0.1, 10}, 60,
                         lf::FocalPlane::through({0.25, 0, 0}, {1, 0, 0})));
  v.emplace_back("focal plane at infinity",
                 request({0.1, 0.1, -0.5}, {0.3, 0, 10}, 50, lf::FocalPlane::infinity()));
  v.emplace_back("facing away", request({0.2, 0.1, -3}, {0.2, 0.1, -13}, 40, plane_z(10)));
  v.emplace_back("triangles straddling the eye plane",
                 request({0.1, 0.0, 0.5}, {10, 0.0, 0.6}, 120, plane_z(10)));
  v.emplace_back("narrow field of view",
                 request({0.0, 0.0, -2}, {0.1, -0.1, 10}, 0.5, plane_z(10)));
  v.emplace_back("wide field of view", request({0.0, 0.0, -0.2}, {0.0, 0.0, 10}, 170, plane_z(10)));
  return v;
}

lf::Rig grid4(bool distort) {
  lf::Rig rig = lf::synthetic_grid_rig(4, 4, 1.0, 160, 120, 50, 1.0, 17);
  if (distort) {
    for (auto& c : rig.cameras) c.intrinsics.k1 = -0.2, c.intrinsics.k2 = 0.05;
    rig.triangles.clear();
    rig.finalize();
  }
  return rig;
}

TEST(GlBackend, ThisBuildHasAWorkingContext) {
  const lf::GlInfo& gl = lf::gl_info();
  ASSERT_TRUE(gl.available) << "no GLES 3 context: " << gl.error
                            << " (scripts/setup.sh installs Mesa's EGL and llvmpipe)";
  EXPECT_FALSE(gl.renderer.empty());
  EXPECT_NE(gl.version.find("OpenGL ES 3"), std::string::npos) << gl.version;
  std::cout << "GL: " << gl.renderer << " | " << gl.version << " | EGL platform " << gl.platform
            << (gl.software ? " (software)" : "") << "\n";
}

TEST(GlBackend, BackendNamesParse) {
  lf::Backend b = lf::Backend::kCpu;
  for (lf::Backend x : {lf::Backend::kAuto, lf::Backend::kCpu, lf::Backend::kGl}) {
    ASSERT_TRUE(lf::parse_backend(lf::backend_name(x), &b));
    EXPECT_EQ(b, x);
  }
  EXPECT_FALSE(lf::parse_backend("GL", &b));
  EXPECT_FALSE(lf::parse_backend("", &b));
}

// auto picks GL only for a hardware GPU; cpu is always cpu; gl is gl here.
TEST(GlBackend, AutoPicksGlOnlyOnHardware) {
  const lf::GlInfo& gl = lf::gl_info();
  ASSERT_TRUE(gl.available) << gl.error;
  std::string why;
  const lf::Backend b = lf::resolve_backend(lf::Backend::kAuto, &why);
  EXPECT_EQ(b, gl.software ? lf::Backend::kCpu : lf::Backend::kGl) << why;
  if (gl.software) {
    EXPECT_TRUE(why.find("software rasteriser") != std::string::npos ||
                why.find("no EGL device is a hardware GPU") != std::string::npos)
        << why;
  }
  EXPECT_EQ(lf::resolve_backend(lf::Backend::kCpu), lf::Backend::kCpu);
  EXPECT_EQ(lf::resolve_backend(lf::Backend::kGl), lf::Backend::kGl);
}

TEST(GlBackend, FragmentsMatchTheCpuKernel) {
  lf::GlRenderer gl;
  for (bool distort : {false, true})
    for (const lf::Sampling sampling : {lf::Sampling::kBilinear, lf::Sampling::kBicubic}) {
      const bool cubic = sampling == lf::Sampling::kBicubic;
      const lf::Rig rig = grid4(distort);
      const auto images = images_of(rig);
      for (size_t i = 0; i < images.size(); ++i) gl.set_image(static_cast<int>(i), images[i]);
      Diff all;
      for (auto [name, req] : views()) {
        req.sampling = sampling;
        const std::string what = name + (distort ? " (distorted)" : "") + (cubic ? " bicubic" : "");
        SCOPED_TRACE(what);
        const lf::ViewGeometry g(rig, req);
        Diff view;
        for (size_t i = 0; i < rig.cameras.size(); ++i) {
          const auto plan = lf::plan_fragment(g, static_cast<int>(i));
          lf::Fragment cpu, out;
          lf::render_fragment(plan, rig.cameras[i], images[i], cpu, lf::Kernel::kScalar);
          lf::describe_fragment(plan, out);
          out.pixels.assign(4 * plan.pixel_count(), 0xAB);  // every byte must be written
          gl.render_pixels(plan, rig.cameras[i], static_cast<int>(i), out.pixels.data());
          ASSERT_EQ(out.pixels.size(), cpu.pixels.size());
          if (plan.empty()) {
            EXPECT_TRUE(out.pixels.empty());
            continue;
          }
          const Diff d = compare(as_image(cpu), as_image(out));
          expect_max3(d, "camera " + std::to_string(i));
          EXPECT_EQ(d.mismatch_off_border, 0u) << "camera " << i;
          view.add(d);
        }
        EXPECT_LE(view.mean(), 1.0);
        all.add(view);
      }
      expect_close(all, distort ? "all views, distorted" : "all views", 100000);
      std::cout << (distort ? "distorted" : "undistorted") << (cubic ? ", bicubic: " : ": ")
                << all.both << " pixels, " << all.differ << " differ, mean |GL - CPU| "
                << all.mean() << " LSB, max " << all.max_abs << ", coverage differs at "
                << all.mismatch << " border pixels\n";
    }
}

// render_fragment() with its own upload equals render_pixels() from a slot;
// a slot without an image of the camera's size is refused.
TEST(GlBackend, FragmentUploadsAndSlotsAreChecked) {
  lf::GlRenderer gl;
  const lf::Rig rig = grid4(false);
  const auto images = images_of(rig);
  const lf::ViewGeometry g(rig, request({0.0, 0.0, -1}, {0.0, 0.0, 10}, 40, plane_z(10)));
  int cam = 0;
  while (lf::plan_fragment(g, cam).empty()) ++cam;
  const auto plan = lf::plan_fragment(g, cam);
  lf::Fragment a, b;
  gl.render_fragment(plan, rig.cameras[cam], images[cam], a);
  gl.set_image(7, images[cam]);
  lf::describe_fragment(plan, b);
  b.pixels.resize(a.pixels.size());
  gl.render_pixels(plan, rig.cameras[cam], 7, b.pixels.data());
  EXPECT_EQ(a.pixels, b.pixels);
  EXPECT_EQ(a.spans, b.spans);
  EXPECT_EQ(a.camera_id, static_cast<uint32_t>(rig.cameras[cam].id));
  std::vector<uint8_t> px(a.pixels.size());
  EXPECT_THROW(gl.render_pixels(plan, rig.cameras[cam], 99, px.data()), std::invalid_argument);
  EXPECT_THROW(gl.set_image(-2, images[cam]), std::invalid_argument);
  EXPECT_THROW(gl.set_image(5000, images[cam]), std::invalid_argument);
  EXPECT_THROW(gl.set_image(1, cv::Mat(10, 10, CV_8UC3)), std::invalid_argument);
  gl.set_image(8, cv::Mat(10, 10, CV_8UC4, cv::Scalar::all(1)));
  EXPECT_THROW(gl.render_pixels(plan, rig.cameras[cam], 8, px.data()), std::invalid_argument);
}

// The whole-view mode (all fragments blended in one target, resolved in a
// final pass, one readback) against lf::render_view.
TEST(GlBackend, WholeViewsMatchTheCpuPipeline) {
  lf::GlRenderer gl;
  for (bool distort : {false, true}) {
    const lf::Rig rig = grid4(distort);
    const auto images = images_of(rig);
    Diff all;
    bool first = true;
    for (const auto& [name, req] : views()) {
      SCOPED_TRACE(name + (distort ? " (distorted)" : ""));
      lf::RenderStats cs, gs;
      const cv::Mat cpu = lf::render_view(rig, images, req, &cs);
      const cv::Mat out = first ? gl.render_view(rig, images, req, &gs)
                                : gl.render_view(rig, req, &gs);  // images stay uploaded
      first = false;
      ASSERT_EQ(out.size(), cpu.size());
      ASSERT_EQ(out.type(), CV_8UC4);
      EXPECT_EQ(gs.fragment_pixels, cs.fragment_pixels);
      EXPECT_EQ(gs.contributing, cs.contributing);
      const Diff d = compare(cpu, out);
      expect_max3(d, name);
      EXPECT_EQ(d.mismatch_off_border, 0u);
      all.add(d);
    }
    expect_close(all, distort ? "whole views, distorted" : "whole views", 50000);
    std::cout << (distort ? "distorted views: " : "views: ") << all.both << " pixels, "
              << all.differ << " differ, mean |GL - CPU| " << all.mean() << " LSB, max "
              << all.max_abs << " (" << all.over3 << " pixels over 3)\n";
  }
  // A larger output than any before reuses and grows the targets.
  const lf::Rig rig = grid4(false);
  const auto images = images_of(rig);
  const auto big = request({0.0, 0.0, -1}, {0.0, 0.0, 10}, 40, plane_z(10), 640, 480);
  const Diff d = compare(lf::render_view(rig, images, big), gl.render_view(rig, images, big));
  expect_close(d, "640x480", 200000);
}

// Compositing received fragments (lfcompositor backend=gl) against
// lf::Compositor: the same frame, and the same fragments refused.
TEST(GlBackend, CompositingMatchesTheCpuCompositor) {
  lf::GlRenderer gl;
  const lf::Rig rig = grid4(true);
  const auto images = images_of(rig);
  Diff all;
  for (const auto& [name, req] : views()) {
    SCOPED_TRACE(name);
    const lf::ViewGeometry g(rig, req);
    std::vector<lf::Fragment> frags(rig.cameras.size());
    for (size_t i = 0; i < rig.cameras.size(); ++i)
      lf::render_fragment(lf::plan_fragment(g, static_cast<int>(i)), rig.cameras[i], images[i],
                          frags[i]);
    // Two that add() refuses: another frame size, and pixels missing.
    lf::Fragment other = frags[5];
    other.out_width += 1;
    frags.push_back(other);
    std::vector<lf::FragmentPixels> in;
    for (const auto& f : frags) in.push_back({&f, f.pixels.data()});
    if (!frags[6].empty()) in.push_back({&frags[6], nullptr});
    // A partial sum with a weight shift (lib/lf/render/composite.h
    // sum_fragments): every camera's fragment twice, so the sums pass 255
    // (shift 1), added by both compositors the same way.
    std::vector<lf::FragmentPixels> twice;
    for (int k = 0; k < 2; ++k)
      for (size_t i = 0; i < rig.cameras.size(); ++i)
        twice.push_back({&frags[i], frags[i].pixels.data()});
    const lf::Fragment sum = lf::sum_fragments(twice);
    if (!sum.empty()) {
      EXPECT_GE(sum.weight_shift, 1);
      in.push_back({&sum, sum.pixels.data()});
    }
    cv::Mat cpu, out;
    lf::Compositor comp;
    const auto cpu_refused = comp.composite(req.view.width, req.view.height, in, cpu);
    const auto gl_refused = gl.composite(req.view.width, req.view.height, in, out);
    ASSERT_EQ(gl_refused.size(), cpu_refused.size());
    for (size_t k = 0; k < gl_refused.size(); ++k) {
      EXPECT_EQ(gl_refused[k].first, cpu_refused[k].first);
      EXPECT_EQ(gl_refused[k].second, cpu_refused[k].second);
    }
    ASSERT_EQ(out.size(), cpu.size());
    const Diff d = compare(cpu, out);
    EXPECT_EQ(d.mismatch, 0u);  // coverage is the fragments' spans: exact
    all.add(d);
  }
  expect_close(all, "composited views", 50000);
  // A shifted sum against a fragment of another colour: the shift weighs
  // it (red counted twice: 2/3 red), not only the renormalisation.
  lf::Fragment red, blue;
  for (lf::Fragment* f : {&red, &blue}) {
    f->out_width = 16, f->out_height = 8;
    f->rect = cv::Rect(2, 1, 10, 5);
    f->spans.assign(5, {2, 12});
    f->pixels.resize(4 * 50);
    for (int p = 0; p < 50; ++p) {
      const bool r = f == &red;
      f->pixels[4 * p] = r ? 200 : 0, f->pixels[4 * p + 2] = r ? 0 : 200;
      f->pixels[4 * p + 1] = 0, f->pixels[4 * p + 3] = 200;
    }
  }
  const lf::Fragment reds =
      lf::sum_fragments({{&red, red.pixels.data()}, {&red, red.pixels.data()}});
  ASSERT_EQ(reds.weight_shift, 1);
  cv::Mat cpu_mix, gl_mix;
  const std::vector<lf::FragmentPixels> mix{{&reds, reds.pixels.data()},
                                            {&blue, blue.pixels.data()}};
  lf::Compositor comp;
  comp.composite(16, 8, mix, cpu_mix);
  gl.composite(16, 8, mix, gl_mix);
  EXPECT_EQ(cpu_mix.at<cv::Vec4b>(3, 5), cv::Vec4b(170, 0, 85, 255));
  EXPECT_EQ(cv::norm(cpu_mix, gl_mix, cv::NORM_INF), 0);
  std::cout << "composited: " << all.both << " pixels, " << all.differ << " differ, max "
            << all.max_abs << "\n";
  cv::Mat out;
  EXPECT_THROW(gl.composite(0, 10, {}, out), std::invalid_argument);
}

// Planned fragments (the whole-view mode of lfcompositor: drawn from the
// cameras' images into the sums, no fragment read back) give the frame of
// the same fragments drawn by render_pixels() and composited, exactly,
// also mixed with received fragments in one composite; distorted cameras.
TEST(GlBackend, PlannedFragmentsEqualDrawnAndCompositedOnes) {
  lf::GlRenderer gl;
  const lf::Rig rig = grid4(true);
  const auto images = images_of(rig);
  for (size_t i = 0; i < images.size(); ++i) gl.set_image(static_cast<int>(i), images[i]);
  size_t planned_pixels = 0;
  for (const auto& [name, req] : views()) {
    SCOPED_TRACE(name);
    const lf::ViewGeometry g(rig, req);
    const int n = static_cast<int>(rig.cameras.size());
    std::vector<lf::FragmentPlan> plans;
    std::vector<lf::Fragment> frags(n);
    for (int i = 0; i < n; ++i) {
      plans.push_back(lf::plan_fragment(g, i));
      lf::describe_fragment(plans[i], frags[i]);
      frags[i].pixels.resize(4 * plans[i].pixel_count());
      gl.render_pixels(plans[i], rig.cameras[i], i, frags[i].pixels.data());
    }
    std::vector<lf::FragmentPixels> drawn, half;
    std::vector<lf::PlannedFragment> planned, other_half;
    for (int i = 0; i < n; ++i) {
      drawn.push_back({&frags[i], frags[i].pixels.data()});
      planned.push_back({&plans[i], &rig.cameras[i], i});
      if (i % 2)
        half.push_back(drawn.back());
      else
        other_half.push_back(planned.back());
      planned_pixels += plans[i].pixel_count();
    }
    const int w = req.view.width, h = req.view.height;
    cv::Mat want, all_planned, mixed;
    gl.composite(w, h, drawn, want);
    EXPECT_TRUE(gl.composite(w, h, {}, planned, all_planned).empty());
    gl.composite(w, h, half, other_half, mixed);
    EXPECT_EQ(cv::norm(all_planned, want, cv::NORM_INF), 0);
    EXPECT_EQ(cv::norm(mixed, want, cv::NORM_INF), 0);
    // The whole-view renderer draws the same sums.
    EXPECT_EQ(cv::norm(gl.render_view(rig, req), want, cv::NORM_INF), 0);
  }
  EXPECT_GT(planned_pixels, 10000u);
  // A plan outside the frame, or a slot without its camera's image.
  const auto req = views().front().second;
  const lf::ViewGeometry g(rig, req);
  lf::FragmentPlan plan;
  for (int i = 0; plan.empty() && i < static_cast<int>(rig.cameras.size()); ++i)
    plan = lf::plan_fragment(g, i);
  ASSERT_FALSE(plan.empty());
  cv::Mat out;
  EXPECT_THROW(gl.composite(plan.rect.x + plan.rect.width - 1, req.view.height, {},
                            {{&plan, &rig.cameras[0], 0}}, out),
               std::invalid_argument);
  EXPECT_THROW(
      gl.composite(req.view.width, req.view.height, {}, {{&plan, &rig.cameras[0], 99}}, out),
      std::invalid_argument);
}

// Meson runs this suite with EGL_PLATFORM=nowhere: no context can be made.
TEST(GlBackend, InterleaveMatchesTheCpuKernel) {
  // A Looking Glass Portrait-sized panel from a 48-view quilt: the shader
  // picks the CPU kernel's view for every sub-pixel but those within float
  // rounding of a view boundary, and there the neighbouring view.
  lf::GlRenderer gl;
  lf::Quilt q;
  q.views = 48, q.cols = 8, q.rows = 6;
  const int tw = 160, th = 120;
  cv::Mat views(th * q.rows, tw * q.cols, CV_8UC4);  // view i: channel values 5i + 1, 2, 3
  cv::Mat noise(views.size(), CV_8UC4);
  cv::randu(noise, 0, 256);
  for (int i = 0; i < q.views; ++i)
    views(lf::quilt_tile(q, views.cols, views.rows, i))
        .setTo(cv::Scalar(5 * i + 1, 5 * i + 2, 5 * i + 3, 255));
  for (int variant = 0; variant < 3; ++variant) {
    lf::DisplayCalibration c;
    c.pitch = 52.58, c.slope = -7.19, c.center = 0.565, c.dpi = 324;
    c.screen_w = 1536, c.screen_h = 2048;
    c.inv_view = variant != 1, c.flip_subp = variant == 2, c.flip_image_x = variant == 1;
    cv::Mat cpu, gpu;
    lf::interleave_quilt(c, q, views, cpu);
    gl.interleave(c, q, views, gpu);
    ASSERT_EQ(gpu.size(), cpu.size());
    long differ = 0, not_neighbour = 0;
    for (int y = 0; y < cpu.rows; ++y)
      for (int x = 0; x < cpu.cols; ++x)
        for (int ch = 0; ch < 4; ++ch) {
          const int a = cpu.ptr<uint8_t>(y)[4 * x + ch], b = gpu.ptr<uint8_t>(y)[4 * x + ch];
          if (a == b) continue;
          differ++;
          const int step = std::abs(a - b) / 5;
          if (ch == 3 || std::abs(a - b) % 5 != 0 || (step != 1 && step != q.views - 1))
            not_neighbour++;
        }
    const double fraction = static_cast<double>(differ) / (3.0 * cpu.total());
    std::printf("interleave variant %d: %ld of %zu sub-pixels differ (%.2e)\n", variant, differ,
                3 * cpu.total(), fraction);
    EXPECT_EQ(not_neighbour, 0) << variant;
    EXPECT_LT(fraction, 1e-3) << variant;
    // Texture content is sampled alike: on a noise quilt the same share.
    lf::interleave_quilt(c, q, noise, cpu);
    gl.interleave(c, q, noise, gpu);
    cv::Mat diff;
    cv::absdiff(cpu, gpu, diff);
    EXPECT_LT(cv::countNonZero(diff.reshape(1)), 3.0 * cpu.total() * 1e-3) << variant;
  }
}

TEST(GlAbsent, AutoFallsBackAndGlFailsClearly) {
  const char* platform = std::getenv("EGL_PLATFORM");
  ASSERT_TRUE(platform && std::string(platform) == "nowhere")
      << "run with EGL_PLATFORM=nowhere (meson test gl_absent)";
  const lf::GlInfo& gl = lf::gl_info();
  EXPECT_FALSE(gl.available);
  EXPECT_FALSE(gl.error.empty());
  std::string why;
  EXPECT_EQ(lf::resolve_backend(lf::Backend::kAuto, &why), lf::Backend::kCpu);
  EXPECT_TRUE(why.find("backend auto: CPU (no GL") == 0 ||
              why == "backend auto: CPU (no EGL device is a hardware GPU)")
      << why;
  EXPECT_EQ(lf::resolve_backend(lf::Backend::kCpu), lf::Backend::kCpu);
  try {
    lf::resolve_backend(lf::Backend::kGl);
    ADD_FAILURE() << "gl resolved without GL";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("GL backend asked for but unavailable"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(lf::GlRenderer(), std::runtime_error);
}

}  // namespace

// lf::Renderer (lib/lf/render/renderer.h), the one interface the elements use, on
// each backend: draw_rect() is draw() laid out as the rect's image (the
// bytes outside the spans untouched), composite() equals the backend's own
// compositing of the same fragments and drawings, a frame with layer-1
// fragments goes to the layer compositor with its drawings drawn first,
// and slots out of range or empty are refused.
TEST(GlBackend, RendererInterfaceDrawsAndCompositesAsEachBackend) {
  const lf::Rig rig = grid4(false);
  const auto images = images_of(rig);
  const lf::ViewRequest req = views().front().second;
  const lf::ViewGeometry g(rig, req);
  const int W = req.view.width, H = req.view.height;
  std::vector<lf::FragmentPlan> plans;
  for (size_t i = 0; i < rig.cameras.size(); ++i)
    plans.push_back(lf::plan_fragment(g, static_cast<int>(i)));
  for (const lf::Backend backend : {lf::Backend::kCpu, lf::Backend::kGl}) {
    SCOPED_TRACE(lf::backend_name(backend));
    const auto r = lf::make_renderer(backend);
    ASSERT_EQ(r->backend(), backend);
    EXPECT_THROW(r->set_image(lf::Renderer::kMaxSlots, images[0], nullptr, 0),
                 std::invalid_argument);
    for (size_t i = 0; i < images.size(); ++i)
      r->set_image(static_cast<int>(i), images[i], &images[i], 7);
    std::vector<lf::Fragment> drawn(plans.size());
    std::vector<lf::FragmentPixels> fragments;
    std::vector<lf::SlotDrawing> drawings;
    for (size_t i = 0; i < plans.size(); ++i) {
      const lf::FragmentPlan& plan = plans[i];
      if (plan.empty()) continue;
      lf::describe_fragment(plan, drawn[i]);
      drawn[i].camera_id = static_cast<uint32_t>(rig.cameras[i].id);
      drawn[i].pixels.assign(4 * plan.pixel_count(), 0xAB);
      r->draw(plan, rig.cameras[i], static_cast<int>(i), drawn[i].pixels.data());
      // The rect's image: span pixels in place, the rest as it was.
      const size_t row_bytes = 4 * static_cast<size_t>(plan.rect.width) + 8;
      std::vector<uint8_t> rect(row_bytes * plan.rect.height, 0xCD);
      r->draw_rect(plan, rig.cameras[i], static_cast<int>(i), rect.data(), row_bytes);
      const uint8_t* px = drawn[i].pixels.data();
      size_t outside = 0, differ = 0;
      for (int y = 0; y < plan.rect.height; ++y) {
        const auto [b, e] = drawn[i].spans[y];
        for (int x = 0; x < plan.rect.width; ++x) {
          const uint8_t* at = rect.data() + y * row_bytes + 4 * x;
          const int ox = plan.rect.x + x;
          if (ox >= b && ox < e) {
            differ += std::memcmp(at, px, 4) != 0;
            px += 4;
          } else {
            outside += at[0] != 0xCD || at[3] != 0xCD;
          }
        }
      }
      EXPECT_EQ(differ, 0u) << "camera " << i;
      EXPECT_EQ(outside, 0u) << "camera " << i;
      (i % 2 ? fragments.push_back({&drawn[i], drawn[i].pixels.data()})
             : drawings.push_back({&plans[i], &rig.cameras[i], static_cast<int>(i)}));
    }
    ASSERT_FALSE(fragments.empty());
    ASSERT_FALSE(drawings.empty());
    // Half drawn here, half as fragments: the frame of all of them drawn.
    cv::Mat via, direct;
    EXPECT_TRUE(r->composite(0, W, H, fragments, drawings, via).empty());
    std::vector<lf::FragmentPixels> all;
    for (const auto& f : drawn)
      if (!f.empty()) all.push_back({&f, f.pixels.data()});
    if (backend == lf::Backend::kCpu) {
      lf::Compositor c;
      c.composite(W, H, all, direct);
    } else {
      lf::GlRenderer gl;
      gl.composite(W, H, all, direct);
    }
    ASSERT_EQ(via.size(), direct.size());
    EXPECT_EQ(cv::norm(via, direct, cv::NORM_INF), 0);
    // The right eye has sums of its own; eye 2 is refused.
    cv::Mat right;
    r->composite(1, W, H, all, {}, right);
    EXPECT_EQ(cv::norm(right, direct, cv::NORM_INF), 0);
    EXPECT_THROW(r->composite(2, W, H, all, {}, right), std::invalid_argument);
    // A frame with a layer-1 fragment: the layer compositor, the drawings
    // drawn first (the same frame as the layer compositor of all drawn).
    lf::Fragment second = *fragments.front().fragment;
    second.layer = 1;
    std::vector<lf::FragmentPixels> with_layer = fragments;
    with_layer.push_back({&second, second.pixels.data()});
    cv::Mat layered, layered_direct;
    EXPECT_TRUE(r->composite(0, W, H, with_layer, drawings, layered).empty());
    std::vector<lf::FragmentPixels> all_layers = all;
    all_layers.push_back({&second, second.pixels.data()});
    lf::LayerCompositor lc;
    lc.composite(W, H, all_layers, layered_direct);
    EXPECT_EQ(cv::norm(layered, layered_direct, cv::NORM_INF), 0);
    // A drawing from an empty slot is refused.
    const auto fresh = lf::make_renderer(backend);
    cv::Mat none;
    if (backend == lf::Backend::kCpu) {
      EXPECT_THROW(fresh->composite(0, W, H, {}, drawings, none), std::invalid_argument);
    }
  }
}
