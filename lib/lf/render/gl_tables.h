// The GL backend's per-view tables (lib/lf/render/gl_render.cpp): the
// fragments' runs and rows as textures, and the camera constants of the
// kernel, computed as the CPU kernel computes them. Internal to
// lib/lf/render, not installed; only in builds with EGL/GLES (LF_HAVE_GL).
#pragma once
#ifdef LF_HAVE_GL

#include <glm/glm.hpp>
#include <vector>

#include "lf/geometry/camera.h"
#include "lf/render/plan.h"
#include "lf/render/render_kernels.h"

namespace lf::gl {

// The runs of the fragments being drawn, as two tables in textures (one
// upload per view, then one rectangle per camera; many thin rectangles, one
// per run, would cost a software rasteriser a triangle setup per run):
//  * runs: 4 texels per run: (x0, x1, y, unused) in output pixels, then the
//    scalar kernel's per-run constants (lf/render/render_kernels.h Consts xa..db)
//    computed as the CPU computes them (double, then float):
//    (xa, xb, ya, yb), (za, zb, na, nb), (da, db, unused, unused);
//  * rows: per row of each fragment's rect, (first run, run count).
// Both tables are kTableWidth texels wide, row after row.
constexpr int kTableWidth = 4096;

// Camera constants of the kernel (lf/render/render.cpp render_pixels).
struct CameraUniforms {
  glm::vec4 limits, focal, distort;
  float r2max = 0;
  bool has_distortion = false;
};

inline CameraUniforms camera_uniforms(const Camera& cam) {
  const Intrinsics& K = cam.intrinsics;
  CameraUniforms u;
  u.limits = {static_cast<float>(cam.width) - 0.5f, static_cast<float>(cam.height) - 0.5f,
              static_cast<float>(cam.width - 1) - 1.0f / 1024.0f,
              static_cast<float>(cam.height - 1) - 1.0f / 1024.0f};
  u.focal = {static_cast<float>(K.fx), static_cast<float>(K.fy), static_cast<float>(K.cx),
             static_cast<float>(K.cy)};
  u.distort = {static_cast<float>(1.0 / K.fx), static_cast<float>(1.0 / K.fy),
               static_cast<float>(K.k1), static_cast<float>(K.k2)};
  const double rf = distortion_fold_radius(K);
  // GLSL ES has no infinity literal; the largest float compares the same.
  u.r2max = std::isfinite(rf) ? static_cast<float>(rf * rf) : 3.4e38f;
  u.has_distortion = K.has_distortion();
  return u;
}

// Appends a plan's runs and its rect's rows to the tables (see above);
// returns the index of its first row in the rows table.
inline int append_tables(const FragmentPlan& plan, std::vector<glm::vec4>& runs,
                         std::vector<glm::ivec2>& rows) {
  const int first_row = static_cast<int>(rows.size());
  rows.resize(rows.size() + plan.rect.height, glm::ivec2(0, 0));
  for (const Run& run : plan.runs) {
    const FragmentPiece& pc = plan.pieces[run.piece];
    const double y = run.y;
    const cv::Matx33d& H = pc.H;
    glm::ivec2& row = rows[first_row + run.y - plan.rect.y];
    if (row.y == 0) row.x = static_cast<int>(runs.size() / 4);
    ++row.y;  // runs are sorted by (y, x0): a row's runs are consecutive
    runs.push_back({static_cast<float>(run.x0), static_cast<float>(run.x1),
                    static_cast<float>(run.y), plan.sampling == Sampling::kBicubic ? 1.0f : 0.0f});
    runs.push_back({static_cast<float>(H(0, 0)), static_cast<float>(H(0, 1) * y + H(0, 2)),
                    static_cast<float>(H(1, 0)), static_cast<float>(H(1, 1) * y + H(1, 2))});
    runs.push_back({static_cast<float>(H(2, 0)), static_cast<float>(H(2, 1) * y + H(2, 2)),
                    static_cast<float>(pc.weight_num.a),
                    static_cast<float>(pc.weight_num.b * y + pc.weight_num.c)});
    runs.push_back({static_cast<float>(pc.weight_den.a),
                    static_cast<float>(pc.weight_den.b * y + pc.weight_den.c), 0.0f, 0.0f});
  }
  return first_row;
}

}  // namespace lf::gl

#endif  // LF_HAVE_GL
