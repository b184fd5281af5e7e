// Fragment planning (lib/lf/render/plan.h, Yang et al. 2002 Section 4.1):
// the output pixels each camera contributes to, as rows of runs.
#include "lf/render/plan.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace lf {

size_t FragmentPlan::pixel_count() const {
  size_t n = 0;
  for (const auto& s : row_spans) n += static_cast<size_t>(s[1] - s[0]);
  return n;
}

namespace {

using Polygon = std::vector<cv::Vec2d>;

// Sutherland-Hodgman against h(p) >= 0, in place. Planning clips a few
// polygons per camera, request after request: the clipped one is built in
// this thread's buffer and swapped in, so that callers whose polygons are
// thread_local too make no allocation once the buffers have grown.
void clip(Polygon& poly, const PixelForm& h) {
  if (h.a == 0 && h.b == 0) {
    if (h.c < 0) poly.clear();
    return;
  }
  thread_local Polygon out;
  out.clear();
  const size_t n = poly.size();
  for (size_t i = 0; i < n; ++i) {
    const cv::Vec2d& p = poly[i];
    const cv::Vec2d& q = poly[(i + 1) % n];
    const double hp = h(p[0], p[1]), hq = h(q[0], q[1]);
    if (hp >= 0) out.push_back(p);
    if ((hp >= 0) != (hq >= 0)) {
      const double t = hp / (hp - hq);
      out.push_back(p + (q - p) * t);
    }
  }
  poly.swap(out);
}

// x-extent of a convex polygon on the horizontal line y (clamped to its y range).
bool row_extent(const Polygon& poly, double y, double& xl, double& xr) {
  double ymin = INFINITY, ymax = -INFINITY;
  for (const auto& p : poly) ymin = std::min(ymin, p[1]), ymax = std::max(ymax, p[1]);
  y = std::clamp(y, ymin, ymax);
  xl = INFINITY, xr = -INFINITY;
  const size_t n = poly.size();
  for (size_t i = 0; i < n; ++i) {
    const cv::Vec2d& p = poly[i];
    const cv::Vec2d& q = poly[(i + 1) % n];
    if ((p[1] <= y && y <= q[1]) || (q[1] <= y && y <= p[1])) {
      double x;
      if (q[1] == p[1]) {
        xl = std::min({xl, p[0], q[0]});
        xr = std::max({xr, p[0], q[0]});
        continue;
      }
      x = p[0] + (q[0] - p[0]) * (y - p[1]) / (q[1] - p[1]);
      xl = std::min(xl, x);
      xr = std::max(xr, x);
    }
  }
  return xl <= xr;
}

PixelForm constant(double c) {
  return {0, 0, c};
}

double max_abs(const PixelForm& f) {
  return std::max({std::abs(f.a), std::abs(f.b), std::abs(f.c)});
}

}  // namespace

namespace {

// For each row in [ylo, yhi] that the convex polygon proposes, the exact
// interval of pixels in [xlo, xhi] where `pred` holds (the predicate's set on
// a row is an interval: an intersection of half-planes), found by shrinking
// the proposal (one pixel wider than the polygon) and growing it again.
template <class Pred, class Emit>
void scan_rows(const Polygon& poly, int ylo, int yhi, int xlo, int xhi, const Pred& pred,
               const Emit& emit) {
  double ymin = INFINITY, ymax = -INFINITY;
  for (const auto& p : poly) ymin = std::min(ymin, p[1]), ymax = std::max(ymax, p[1]);
  const int y0 = std::max(ylo, static_cast<int>(std::floor(ymin)) - 1);
  const int y1 = std::min(yhi, static_cast<int>(std::ceil(ymax)) + 1);
  for (int y = y0; y <= y1; ++y) {
    double xl, xr;
    if (!row_extent(poly, y, xl, xr)) continue;
    int a = std::clamp(static_cast<int>(std::floor(xl)) - 1, xlo, xhi);
    int b = std::clamp(static_cast<int>(std::ceil(xr)) + 1, xlo, xhi);
    const int a0 = a, b0 = b;
    while (a <= b && !pred(a, y)) ++a;
    while (b >= a && !pred(b, y)) --b;
    if (a > b) continue;
    // An end that moved in stops where the predicate was just found false;
    // only an end that did not may grow.
    if (a == a0)
      while (a > xlo && pred(a - 1, y)) --a;
    if (b == b0)
      while (b < xhi && pred(b + 1, y)) ++b;
    emit(y, a, b + 1);
  }
}

// Whether the linear form is positive at every pixel of [x0, x1) x [y0, y1)
// with a margin that rounding cannot cross (checked at the corners).
bool positive_on(const PixelForm& f, int x0, int y0, int x1, int y1) {
  const double margin =
      1e-9 * (std::abs(f.a) * (x1 + 1) + std::abs(f.b) * (y1 + 1) + std::abs(f.c));
  for (int x : {x0, x1 - 1})
    for (int y : {y0, y1 - 1})
      if (!(f(x, y) > margin)) return false;
  return true;
}

FragmentPiece make_piece(const cv::Matx33d& H, int sf, const PixelForm& num, const PixelForm& den) {
  FragmentPiece piece;
  piece.H = H * static_cast<double>(sf);
  piece.H *= 1.0 / cv::norm(piece.H);
  piece.weight_num = num;
  piece.weight_den = den;
  return piece;
}

// A part of a camera-plane simplex that holds the planned camera (in
// `slot`), on one side `sd` of the camera plane.
// With a ULR aperture, a half of a blending-field cell instead (`ulr`: its
// cell and half, lf/render/plan.h ViewGeometry::in_ulr_half).
struct Part {
  int s, slot, sd;
  bool single;  // one camera, or the eye on the camera plane: no side to check
  PixelForm num, den;
  Polygon base = {};
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;      // bounding box of base
  std::vector<std::array<int, 3>> rows = {};  // with a surface: (y, x0, x1) where the weight is > 0
  std::array<int, 3> ulr{-1, -1, -1};         // cx, cy, half
  bool ulr_all_positive = false;              // the weight at its three vertices
};

// Pixels [a, b) of row y in ULR half (cx, cy, half) (ViewGeometry::
// in_ulr_half), within [x0, x1) (inside the cell's columns).
std::array<int, 2> ulr_half_span(int cx, int cy, int half, int y, int x0, int x1) {
  const int cx0 = cx * kUlrGrid, v = y - cy * kUlrGrid;  // half 0: u >= v; half 1: u < v
  return half == 0 ? std::array<int, 2>{std::max(x0, cx0 + v), x1}
                   : std::array<int, 2>{x0, std::min(x1, cx0 + v)};
}

// Whether the camera's weight in the part is positive at pixel (x, y).
bool weighted(const ViewGeometry& g, const Part& part, int x, int y) {
  if (part.ulr[0] >= 0)
    return ViewGeometry::in_ulr_half(x, y, part.ulr[0], part.ulr[1], part.ulr[2]) &&
           part.num(x, y) > 0;
  if (!part.single) {
    const double dn = g.camera_plane_denominator()(x, y);
    if ((dn > 0 ? 1 : -1) != part.sd || dn == 0) return false;
  }
  if (g.request().aperture_scale != 1.0) return g.inside_scaled(part.s, part.slot, x, y);
  return g.weight_positive(part.s, part.slot, x, y);
}

// The parts of the camera plane's simplices that hold camera `index`, as
// polygons of output pixels: they do not depend on the focal plane.
std::vector<Part> camera_parts(const ViewGeometry& g, int index) {
  const Rig& rig = g.rig();
  const int W = g.width(), H = g.height();
  std::vector<Part> parts;
  const cv::Vec2d frame[4] = {{-0.5, -0.5}, {W - 0.5, -0.5}, {W - 0.5, H - 0.5}, {-0.5, H - 0.5}};
  const auto& simplices = rig.simplices();
  // ULR: the halves of the blending field's cells where the camera has
  // weight at a vertex (linear over the half: positive somewhere in it).
  for (int cy = 0; cy < g.ulr_rows(); ++cy)
    for (int cx = 0; cx < g.ulr_cols(); ++cx)
      for (int half = 0; half < 2; ++half) {
        const int G = kUlrGrid;
        const double w0 = g.ulr_weight(index, cx, cy), w2 = g.ulr_weight(index, cx + 1, cy + 1);
        const double w1 =
            half == 0 ? g.ulr_weight(index, cx + 1, cy) : g.ulr_weight(index, cx, cy + 1);
        if (!(w0 > 0 || w1 > 0 || w2 > 0)) continue;
        const int id = -1 - ((cy * g.ulr_cols() + cx) * 2 + half);  // unique among parts
        Part part{id, 0, 1, true, g.ulr_form(index, cx, cy, half), constant(1.0)};
        part.ulr = {cx, cy, half};
        part.ulr_all_positive = w0 > 0 && w1 > 0 && w2 > 0;
        const double x0 = cx * G - 0.5, y0 = cy * G - 0.5;
        const double x1 = std::min(W, (cx + 1) * G) - 0.5, y1 = std::min(H, (cy + 1) * G) - 0.5;
        part.base = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
        part.x0 = x0, part.y0 = y0, part.x1 = x1, part.y1 = y1;
        if (!g.request().surface.empty() && part.ulr_all_positive) {
          // Weighted throughout: the half's own rows, in integers.
          for (int y = cy * G; y < std::min(H, (cy + 1) * G); ++y) {
            const auto [a, b] = ulr_half_span(cx, cy, half, y, cx * G, std::min(W, (cx + 1) * G));
            if (a < b) part.rows.push_back({y, a, b});
          }
        } else if (!g.request().surface.empty()) {
          scan_rows(
              part.base, 0, H - 1, 0, W - 1, [&](int x, int y) { return weighted(g, part, x, y); },
              [&](int y, int a, int b) {
                part.rows.push_back({y, a, b});
              });
        }
        parts.push_back(std::move(part));
      }
  for (size_t s = 0; s < simplices.size() && g.ulr_cols() == 0; ++s) {
    const Simplex& sx = simplices[s];
    int slot = -1;
    for (int k = 0; k < sx.size; ++k)
      if (sx.cams[k] == index) slot = k;
    if (slot < 0) continue;
    // Weight forms of this camera in this simplex.
    PixelForm num, den;
    if (sx.size == 1) {
      num = den = constant(1.0);
    } else if (g.eye_on_camera_plane()) {
      double sum = 0;
      for (int k = 0; k < sx.size; ++k) sum += g.facet_at_eye(sx.facet[k], sx.sign[k]);
      num = constant(g.facet_at_eye(sx.facet[slot], sx.sign[slot]));
      den = constant(sum);
    } else {
      num = g.facet_form(sx.facet[slot], sx.sign[slot]);
      for (int k = 0; k < sx.size; ++k) den = den + g.facet_form(sx.facet[k], sx.sign[k]);
    }
    // A wider aperture (scale k): the camera's barycentric b becomes
    // (b + k - 1) / k, positive on the simplex scaled by k about the camera.
    const double k = g.request().aperture_scale;
    PixelForm slot_facet;
    if (sx.size > 1) slot_facet = g.facet_form(sx.facet[slot], sx.sign[slot]);
    if (k != 1.0 && sx.size > 1) {
      slot_facet = slot_facet + den * (k - 1.0);
      num = num + den * (k - 1.0);
      den = den * k;
    }
    const double dscale = max_abs(den);
    if (dscale > 0) num = num * (1.0 / dscale), den = den * (1.0 / dscale);

    // Orientation pieces of the camera plane (sign of D_n).
    const bool single = sx.size == 1 || g.eye_on_camera_plane();
    for (int sd : {1, -1}) {
      if (single && sd < 0) break;
      thread_local Polygon base;  // (clip)
      base.assign(std::begin(frame), std::end(frame));
      if (!single) {
        clip(base, g.camera_plane_denominator() * sd);
        for (int j = 0; j < sx.size && !base.empty(); ++j)
          clip(base, (j == slot ? slot_facet : g.facet_form(sx.facet[j], sx.sign[j])) * sd);
      } else if (sx.size > 1) {
        const Part probe{static_cast<int>(s), slot, sd, single, num, den};
        if (!weighted(g, probe, 0, 0)) break;
      }
      if (base.size() < 3) continue;
      Part part{static_cast<int>(s), slot,      sd, single, num, den, base, INFINITY, INFINITY,
                -INFINITY,           -INFINITY, {}};
      for (const auto& p : base) {
        part.x0 = std::min(part.x0, p[0]), part.x1 = std::max(part.x1, p[0]);
        part.y0 = std::min(part.y0, p[1]), part.y1 = std::max(part.y1, p[1]);
      }
      if (!g.request().surface.empty()) {
        // Where the camera's weight is positive, whatever the focal plane.
        scan_rows(
            part.base, 0, H - 1, 0, W - 1, [&](int x, int y) { return weighted(g, part, x, y); },
            [&](int y, int a, int b) {
              part.rows.push_back({y, a, b});
            });
      }
      parts.push_back(std::move(part));
    }
  }

  return parts;
}

// Camera `index`'s plan over `regions` from its parts.
FragmentPlan plan_regions(const ViewGeometry& g, int index, const std::vector<Part>& parts,
                          const std::vector<FocalRegion>& regions, int layer) {
  FragmentPlan plan;
  plan.layer = layer;
  plan.camera_index = index;
  plan.camera_id = g.rig().cameras[index].id;
  plan.out_width = g.width();
  plan.out_height = g.height();
  plan.sampling = g.request().sampling;
  if (regions.empty()) return plan;
  const int W = g.width(), H = g.height();
  std::map<std::array<int, 4>, int> piece_keys;  // -> index in plan.pieces

  for (const FocalRegion& reg : regions) {
    const bool whole = reg.x0 == 0 && reg.y0 == 0 && reg.x1 == W && reg.y1 == H;
    const int fp = reg.plane;
    const cv::Matx33d& Hc = g.homography(index, fp);
    const PixelForm zc{Hc(2, 0), Hc(2, 1), Hc(2, 2)};
    // Pieces by (simplex, camera-plane side, focal side, plane), made when
    // their first run is.
    auto piece_id = [&](const Part& part, int sf) {
      const auto it = piece_keys.find({part.s, part.sd, sf, fp});
      return it == piece_keys.end() ? static_cast<int>(plan.pieces.size()) : it->second;
    };
    auto add_run = [&](int id, const Part& part, int sf, int y, int a, int b) {
      if (id == static_cast<int>(plan.pieces.size())) {
        plan.pieces.push_back(make_piece(Hc, sf, part.num, part.den));
        piece_keys[{part.s, part.sd, sf, fp}] = id;
      }
      plan.runs.push_back({y, a, b, id});
    };
    for (const Part& part : parts) {
      // The part within the region (a margin of one pixel: the exact
      // predicate decides the pixels).
      if (part.x1 < reg.x0 - 1.5 || part.x0 > reg.x1 + 0.5 || part.y1 < reg.y0 - 1.5 ||
          part.y0 > reg.y1 + 0.5)
        continue;
      // A ULR half whose three vertex weights are positive, in a region
      // whose focal points the camera sees (the usual case): its pixels are
      // the half's, row by row, in integers (ViewGeometry::in_ulr_half).
      if (part.ulr[0] >= 0 && part.ulr_all_positive) {
        const int G = kUlrGrid, cx0 = part.ulr[0] * G, cy0 = part.ulr[1] * G;
        const int x0 = std::max(cx0, reg.x0), x1 = std::min(cx0 + G, reg.x1);
        const int y0 = std::max(cy0, reg.y0), y1 = std::min(cy0 + G, reg.y1);
        if (x0 < x1 && y0 < y1 &&
            (g.focal_at_infinity(fp) || positive_on(g.focal_denominator(fp), x0, y0, x1, y1)) &&
            positive_on(zc, x0, y0, x1, y1)) {
          const int id = piece_id(part, 1);
          for (int y = y0; y < y1; ++y) {
            const auto [a, b] = ulr_half_span(part.ulr[0], part.ulr[1], part.ulr[2], y, x0, x1);
            if (a < b) add_run(id, part, 1, y, a, b);
          }
          continue;
        }
      }
      // A region whose focal points are all in front of the camera and on
      // the focal plane's positive side (the usual case) is the part's
      // weighted pixels there, without evaluating any predicate again.
      if (!whole &&
          (g.focal_at_infinity(fp) ||
           positive_on(g.focal_denominator(fp), reg.x0, reg.y0, reg.x1, reg.y1)) &&
          positive_on(zc, reg.x0, reg.y0, reg.x1, reg.y1)) {
        const int id = piece_id(part, 1);
        auto r = std::lower_bound(part.rows.begin(), part.rows.end(), reg.y0,
                                  [](const std::array<int, 3>& row, int y) { return row[0] < y; });
        for (; r != part.rows.end() && (*r)[0] < reg.y1; ++r) {
          const int a = std::max((*r)[1], reg.x0), b = std::min((*r)[2], reg.x1);
          if (a < b) add_run(id, part, 1, (*r)[0], a, b);
        }
        continue;
      }
      thread_local Polygon base, poly;  // (clip)
      base = part.base;
      if (!whole) {
        clip(base, {1, 0, 0.5 - reg.x0});
        if (base.size() >= 3) clip(base, {-1, 0, reg.x1 - 0.5});
        if (base.size() >= 3) clip(base, {0, 1, 0.5 - reg.y0});
        if (base.size() >= 3) clip(base, {0, -1, reg.y1 - 0.5});
        if (base.size() < 3) continue;
      }
      // ... times pieces of the focal plane's orientation.
      for (int sf : {1, -1}) {
        if (g.focal_at_infinity(fp) && sf < 0) break;
        poly = base;
        if (!g.focal_at_infinity(fp)) clip(poly, g.focal_denominator(fp) * sf);
        if (poly.size() >= 3) clip(poly, zc * sf);
        if (poly.size() < 3) continue;
        const int id = piece_id(part, sf);
        auto pred = [&](int x, int y) {
          return g.focal_sign(x, y, fp) == sf && zc(x, y) * sf > 0 && weighted(g, part, x, y);
        };
        scan_rows(poly, reg.y0, reg.y1 - 1, reg.x0, reg.x1 - 1, pred,
                  [&](int y, int a, int b) { add_run(id, part, sf, y, a, b); });
      }
    }
  }
  // Most cameras of a rig hold none of a view (its rays cross the camera
  // plane in a few simplices): they return here, before any sorting.
  if (plan.runs.empty()) return plan;
  // Sort by (y, x0): rows by counting, each row's few runs by insertion, in
  // this thread's buffers (reused plan after plan: a plan is made per
  // camera and request, and the heap's lock is shared with the compositor
  // thread that frees the plans).
  {
    thread_local std::vector<int> start, fill;
    thread_local std::vector<Run> sorted;
    start.assign(H + 1, 0);
    for (const Run& r : plan.runs) ++start[r.y + 1];
    for (int y = 0; y < H; ++y) start[y + 1] += start[y];
    sorted.resize(plan.runs.size());
    fill.assign(start.begin(), start.end() - 1);
    for (const Run& r : plan.runs) sorted[fill[r.y]++] = r;
    for (int y = 0; y < H; ++y)
      for (int k = start[y] + 1; k < start[y + 1]; ++k)
        for (int j = k; j > start[y] && sorted[j].x0 < sorted[j - 1].x0; --j)
          std::swap(sorted[j], sorted[j - 1]);
    std::copy(sorted.begin(), sorted.end(), plan.runs.begin());
  }
  // Runs of one piece that touch across a region edge become one.
  size_t kept = 0;
  for (size_t k = 1; k < plan.runs.size(); ++k) {
    Run& last = plan.runs[kept];
    const Run& r = plan.runs[k];
    if (r.y == last.y && r.piece == last.piece && r.x0 == last.x1)
      last.x1 = r.x1;
    else
      plan.runs[++kept] = r;
  }
  plan.runs.resize(kept + 1);
  int x0 = W, x1 = 0;
  for (const Run& r : plan.runs) x0 = std::min(x0, r.x0), x1 = std::max(x1, r.x1);
  const int ry0 = plan.runs.front().y, ry1 = plan.runs.back().y;
  plan.rect = cv::Rect(x0, ry0, x1 - x0, ry1 - ry0 + 1);
  // Each row's hull; a row without runs is empty at rect.x (x1 < x0 marks
  // a row not seen yet).
  plan.row_spans.assign(plan.rect.height, {W, -1});
  for (const Run& r : plan.runs) {
    auto& span = plan.row_spans[r.y - ry0];
    span[0] = std::min(span[0], r.x0);
    span[1] = std::max(span[1], r.x1);
  }
  for (auto& span : plan.row_spans)
    if (span[1] < span[0]) span = {plan.rect.x, plan.rect.x};
  return plan;
}

}  // namespace

FragmentPlan plan_fragment(const ViewGeometry& g, int index, int layer) {
  const std::vector<FocalRegion>& regions = g.regions(layer);
  return plan_regions(g, index, regions.empty() ? std::vector<Part>{} : camera_parts(g, index),
                      regions, layer);
}

bool plan_is_plane_free(const ViewGeometry& g, int index) {
  const int W = g.width(), H = g.height();
  const cv::Matx33d& Hc = g.homography(index, 0);
  return g.request().surface.empty() && g.ulr_cols() == 0 &&
         (g.focal_at_infinity(0) || positive_on(g.focal_denominator(0), 0, 0, W, H)) &&
         positive_on({Hc(2, 0), Hc(2, 1), Hc(2, 2)}, 0, 0, W, H);
}

void aim_plan(const ViewGeometry& g, FragmentPlan& plan) {
  for (FragmentPiece& pc : plan.pieces)
    pc.H = make_piece(g.homography(plan.camera_index, 0), 1, pc.weight_num, pc.weight_den).H;
}

std::array<FragmentPlan, 2> plan_fragment_layers(const ViewGeometry& g, int index) {
  const std::vector<Part> parts = camera_parts(g, index);
  return {plan_regions(g, index, parts, g.regions(0), 0),
          plan_regions(g, index, parts, g.regions(1), 1)};
}

}  // namespace lf
