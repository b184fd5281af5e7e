#include "lf/render/plan.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace lf {

namespace {
PixelForm form_from(const cv::Vec3d& coeffs) {
  return {coeffs[0], coeffs[1], coeffs[2]};
}

// The point of segment ab nearest p.
cv::Vec2d nearest_on_segment(const cv::Vec2d& p, const cv::Vec2d& a, const cv::Vec2d& b) {
  const cv::Vec2d d = b - a;
  const double len2 = d.dot(d);
  const double t = len2 > 0 ? std::clamp((p - a).dot(d) / len2, 0.0, 1.0) : 0.0;
  return a + d * t;
}

// An eye on the camera plane sees every ray cross the plane at the eye, so
// the tent weighs all of its pixels with the barycentrics of that one point
// (plan_parts). Outside the triangulation they are all zero somewhere and
// the view would be black, also for an eye that is on the hull's border
// up to the cameras' scatter (an in-between camera of a sparser grid). Such
// an eye is moved to the nearest point of the nearest triangle, nudged a
// millionth of a spacing towards its centroid so that the two cameras of
// the nearest edge weigh it (and not a rounding error): the view is then
// the boundary's, as the nearest cameras see it.
cv::Vec2d into_triangulation(const Rig& rig, const cv::Vec2d& e) {
  const auto& pos = rig.plane_positions();
  double best = INFINITY;
  cv::Vec2d snapped = e;
  for (const Simplex& sx : rig.simplices()) {
    if (sx.size != 3) continue;
    bool inside = true;
    for (int k = 0; k < 3; ++k) inside = inside && rig.facets()[sx.facet[k]](e) * sx.sign[k] >= 0;
    if (inside) return e;
    const cv::Vec2d a = pos[sx.cams[0]], b = pos[sx.cams[1]], c = pos[sx.cams[2]];
    for (const cv::Vec2d& q :
         {nearest_on_segment(e, a, b), nearest_on_segment(e, b, c), nearest_on_segment(e, c, a)}) {
      const double d = cv::norm(q - e);
      if (d < best) {
        best = d;
        const cv::Vec2d centre = (a + b + c) * (1.0 / 3.0);
        const double to_centre = cv::norm(centre - q);
        snapped = to_centre > 0 ? q + (centre - q) * (1e-6 * rig.typical_spacing() / to_centre) : q;
      }
    }
  }
  return snapped;
}
}  // namespace

ViewGeometry::ViewGeometry(const Rig& rig, const ViewRequest& request, int only_camera,
                           std::shared_ptr<const UlrField> ulr)
    : rig_(&rig), req_(request) {
  validate(req_);
  const VirtualView& v = req_.view;
  const cv::Matx33d Kinv = v.intrinsics().K().inv();
  M_ = v.R.t() * Kinv;
  const CameraPlane& P = rig.plane();
  const cv::Vec3d E = v.position;
  eye_dist_ = P.signed_distance(E);
  // Snap an eye that is on the plane up to rounding of the plane fit itself.
  const double scale = std::max(cv::norm(E - P.origin), rig.typical_spacing());
  if (std::abs(eye_dist_) <= 1e-15 * scale) eye_dist_ = 0.0;
  eye2d_ = P.to_plane(E);
  if (eye_dist_ == 0.0 && rig.dimension() == 2) eye2d_ = into_triangulation(rig, eye2d_);
  const cv::Matx33d Mt = M_.t();
  dn_ = form_from(Mt * P.normal);
  const PixelForm ds = form_from(Mt * P.u), dt = form_from(Mt * P.v);
  for (const Form2& f : rig.facets()) {
    const double at_eye = f(eye2d_);
    facet_eye_.push_back(at_eye);
    facet_px_.push_back(dn_ * at_eye + (ds * f.a + dt * f.b) * (-eye_dist_));
  }
  if (req_.surface.empty())
    planes_ = {req_.focal_plane};
  else
    planes_ = req_.surface.planes;
  ncam_ = static_cast<int>(rig.cameras.size());
  only_ = only_camera >= 0 && only_camera < ncam_ ? only_camera : -1;
  H_.resize(planes_.size() * (only_ >= 0 ? 1 : rig.cameras.size()));
  for (size_t p = 0; p < planes_.size(); ++p) {
    const FocalPlane& fp = planes_[p];
    fw_.push_back(form_from(Mt * fp.n));
    const size_t first = only_ >= 0 ? only_ : 0, last = only_ >= 0 ? only_ + 1 : ncam_;
    for (size_t i = first; i < last; ++i) {
      const Camera& c = rig.cameras[i];
      const cv::Matx33d& R = c.extrinsics.R;
      cv::Matx33d A;
      if (fp.at_infinity()) {
        A = R;
      } else {
        const cv::Vec3d q = R * E + c.extrinsics.t;
        A = cv::Matx33d(q[0] * fp.n[0], q[0] * fp.n[1], q[0] * fp.n[2], q[1] * fp.n[0],
                        q[1] * fp.n[1], q[1] * fp.n[2], q[2] * fp.n[0], q[2] * fp.n[1],
                        q[2] * fp.n[2]) -
            R * (fp.n.dot(E) + fp.d);
      }
      H_[only_ >= 0 ? p : p * ncam_ + i] = c.intrinsics.K() * A * M_;
    }
  }
  if (req_.aperture == Aperture::kUlr) {
    const int G = kUlrGrid;
    if (ulr && ulr->cols == (v.width + G - 1) / G && ulr->rows == (v.height + G - 1) / G &&
        ulr->cameras == ncam_ &&
        ulr->w.size() == static_cast<size_t>(ulr->cols + 1) * (ulr->rows + 1) * ncam_)
      ulr_ = std::move(ulr);
    else
      ulr_ = compute_ulr();
  }
  // Two-plane tiles: whether the second plane is the nearer, along the ray
  // of the tile's centre pixel (a plane behind the eye, parallel to the ray
  // or at infinity is infinitely far).
  const FocalSurface& fs = req_.surface;
  if (fs.two_planes()) {
    auto along = [&](const FocalPlane& p, const cv::Vec3d& D) {
      const double t = -(p.n.dot(E) + p.d) / p.n.dot(D);
      return p.at_infinity() || !(t > 0) || !std::isfinite(t) ? INFINITY : t;
    };
    second_nearer_.assign(fs.plane_of.size(), 0);
    for (int r = 0; r < fs.rows; ++r)
      for (int c = 0; c < fs.cols; ++c) {
        const int t = r * fs.cols + c;
        if (fs.second_of[t] == FocalSurface::kNone) continue;
        const double x = (std::min(v.width, (c + 1) * fs.tile) + c * fs.tile - 1) * 0.5;
        const double y = (std::min(v.height, (r + 1) * fs.tile) + r * fs.tile - 1) * 0.5;
        const cv::Vec3d D = ray(x, y);
        second_nearer_[t] =
            along(fs.planes[fs.second_of[t]], D) < along(fs.planes[fs.plane_of[t]], D) ? 1 : 0;
      }
  }
}

int ViewGeometry::layer_plane(int layer, int tile) const {
  const FocalSurface& fs = req_.surface;
  if (fs.empty()) return layer == 0 ? 0 : -1;
  const int a = fs.plane_of[tile];
  const int b = fs.second_of.empty() ? FocalSurface::kNone : fs.second_of[tile];
  if (b == FocalSurface::kNone) return layer == 0 ? a : -1;
  return (layer == 1) == (second_nearer_[tile] != 0) ? b : a;
}

// The blending field of a kUlr request (lf/geometry/view.h Aperture).
std::shared_ptr<const UlrField> ViewGeometry::compute_ulr() const {
  const Rig& rig = *rig_;
  const int W = req_.view.width, H = req_.view.height, G = kUlrGrid;
  auto field = std::make_shared<UlrField>();
  field->cols = (W + G - 1) / G;
  field->rows = (H + G - 1) / G;
  field->cameras = ncam_;
  field->w.assign(static_cast<size_t>(field->cols + 1) * (field->rows + 1) * ncam_, 0.0);
  const cv::Vec3d E = req_.view.position;
  const int k = req_.ulr_cameras;
  const double far = 1e4 * std::max(rig.typical_spacing(), cv::norm(E - rig.plane().origin));
  std::vector<std::pair<double, int>> ranked;
  for (int vy = 0; vy <= field->rows; ++vy)
    for (int vx = 0; vx <= field->cols; ++vx) {
      const double x = vx * G, y = vy * G;
      const cv::Vec3d D = ray(x, y);
      // The focal point: through the plane of the vertex's tile (the
      // nearest pixel's), or far along the ray where that plane is at
      // infinity or behind the eye.
      const FocalPlane& fp = planes_[plane_at(std::min(static_cast<int>(x), W - 1),
                                              std::min(static_cast<int>(y), H - 1))];
      const double dn = fp.n.dot(D);
      const double t = fp.at_infinity() || dn == 0 ? -1 : -(fp.n.dot(E) + fp.d) / dn;
      const cv::Vec3d F = t > 0 ? E + t * D : E + D * (far / cv::norm(D));
      const cv::Vec3d to_eye = F - E;
      const double eye_dist = cv::norm(to_eye);
      ranked.clear();
      for (int i = 0; i < ncam_; ++i) {
        const Camera& c = rig.cameras[i];
        const auto px = c.project(F);
        if (!px || (*px)[0] < -0.5 || (*px)[1] < -0.5 || (*px)[0] > c.width - 0.5 ||
            (*px)[1] > c.height - 0.5)
          continue;  // the camera does not see the focal point
        const cv::Vec3d from_cam = F - c.center();
        const double ang = std::atan2(cv::norm(from_cam.cross(to_eye)), from_cam.dot(to_eye));
        const double res = std::max(0.0, cv::norm(from_cam) - eye_dist) / eye_dist;
        ranked.push_back({(1 - kUlrResolutionWeight) * ang + kUlrResolutionWeight * res, i});
      }
      if (ranked.empty()) continue;
      std::sort(ranked.begin(), ranked.end());
      // The threshold: the (k+1)-th penalty; where that ties with the 2nd,
      // the first penalty above the 2nd (all that tie with it blend), or
      // 1.001 x the largest when none is.
      const int n = static_cast<int>(ranked.size());
      int m = std::min(k, n);
      double thresh = n > k ? ranked[k].first : 1.001 * ranked.back().first;
      if (n >= 2 && !(thresh > ranked[1].first)) {
        m = 1;
        while (m < n && ranked[m].first <= ranked[1].first) ++m;
        thresh = m < n ? ranked[m].first : 1.001 * ranked[1].first;
      }
      double* w = &field->w[(static_cast<size_t>(vy) * (field->cols + 1) + vx) * ncam_];
      double sum = 0;
      for (int j = 0; j < m; ++j) {
        // Penalties all 0 (a threshold of 0): equal weights.
        const double v = thresh > 0 ? std::max(0.0, 1.0 - ranked[j].first / thresh) : 1.0;
        w[ranked[j].second] = v;
        sum += v;
      }
      if (sum > 0)
        for (int j = 0; j < m; ++j) w[ranked[j].second] /= sum;
    }
  return field;
}

PixelForm ViewGeometry::ulr_form(int index, int cx, int cy, int half) const {
  const double G = kUlrGrid;
  const double w00 = ulr_weight(index, cx, cy), w11 = ulr_weight(index, cx + 1, cy + 1);
  double a, b;
  if (half == 0) {  // vertices (0, 0), (G, 0), (G, G)
    const double w10 = ulr_weight(index, cx + 1, cy);
    a = (w10 - w00) / G, b = (w11 - w10) / G;
  } else {  // vertices (0, 0), (0, G), (G, G)
    const double w01 = ulr_weight(index, cx, cy + 1);
    a = (w11 - w01) / G, b = (w01 - w00) / G;
  }
  return {a, b, w00 - a * cx * G - b * cy * G};
}

int ViewGeometry::focal_sign(double x, double y, int p) const {
  if (planes_[p].at_infinity()) return 1;
  return fw_[p](x, y) < 0 ? -1 : 1;
}

bool ViewGeometry::visible(int index, int x, int y) const {
  const int p = plane_at(x, y);
  const cv::Matx33d& H = homography(index, p);
  const double z = H(2, 0) * x + H(2, 1) * y + H(2, 2);
  return focal_sign(x, y, p) * z > 0;
}

PixelForm ViewGeometry::facet_form(int facet, int sign) const {
  return facet_px_[facet] * sign;
}
double ViewGeometry::facet_at_eye(int facet, int sign) const {
  return facet_eye_[facet] * sign;
}

bool ViewGeometry::tie_positive(int facet, int sign) const {
  // Perturb X by (eps, eps^2): the sign of the form's gradient decides.
  const Form2& f = rig_->facets()[facet];
  const double a = f.a * sign, b = f.b * sign;
  return a > 0 || (a == 0 && b > 0);
}

bool ViewGeometry::facet_values(const Simplex& sx, double x, double y, std::array<double, 3>& v,
                                double& orient) const {
  v = {0, 0, 0};
  orient = 1.0;
  if (eye_dist_ == 0.0) {
    for (int k = 0; k < sx.size; ++k) v[k] = facet_at_eye(sx.facet[k], sx.sign[k]);
    return true;
  }
  const double dn = dn_(x, y);
  if (dn == 0.0) return false;
  orient = dn > 0 ? 1.0 : -1.0;
  // As facet_form(...)(x, y): a sign of +-1 commutes with every rounding.
  for (int k = 0; k < sx.size; ++k) v[k] = facet_px_[sx.facet[k]](x, y) * sx.sign[k];
  return true;
}

bool ViewGeometry::facet_sums(int s, double x, double y, std::array<double, 3>& v,
                              double& sum) const {
  const Simplex& sx = rig_->simplices()[s];
  if (sx.size == 1) {
    v = {1.0, 0.0, 0.0};
    sum = 1.0;
    return true;
  }
  double orient;
  if (!facet_values(sx, x, y, v, orient)) return false;
  sum = 0;
  for (int k = 0; k < sx.size; ++k) {
    const double e = v[k] * orient;
    if (e < 0 || (e == 0 && !tie_positive(sx.facet[k], sx.sign[k]))) return false;
    sum += v[k];
  }
  return true;
}

bool ViewGeometry::inside(int s, double x, double y, std::array<double, 3>* w) const {
  std::array<double, 3> v;
  double sum;
  if (!facet_sums(s, x, y, v, sum)) return false;
  if (w) {
    *w = {0, 0, 0};
    for (int k = 0; k < rig_->simplices()[s].size; ++k) (*w)[k] = std::clamp(v[k] / sum, 0.0, 1.0);
  }
  return true;
}

bool ViewGeometry::weight_positive(int s, int slot, double x, double y) const {
  std::array<double, 3> v;
  double sum;
  return facet_sums(s, x, y, v, sum) && std::clamp(v[slot] / sum, 0.0, 1.0) > 0;
}

bool ViewGeometry::inside_scaled(int s, int slot, double x, double y, double* weight) const {
  const Simplex& sx = rig_->simplices()[s];
  const double k = req_.aperture_scale;
  if (sx.size == 1) {
    if (weight) *weight = 1.0;
    return true;
  }
  std::array<double, 3> v;
  double orient;
  if (!facet_values(sx, x, y, v, orient)) return false;
  double sum = 0;
  for (int j = 0; j < sx.size; ++j) {
    sum += v[j];
    if (j == slot) continue;
    const double e = v[j] * orient;
    if (e < 0 || (e == 0 && !tie_positive(sx.facet[j], sx.sign[j]))) return false;
  }
  const double num = v[slot] + (k - 1.0) * sum;
  if (!(num * orient > 0)) return false;
  if (weight) *weight = std::clamp(num / (k * sum), 0.0, 1.0);
  return true;
}

ApertureSample ViewGeometry::locate(double x, double y) const {
  ApertureSample out;
  const auto& simplices = rig_->simplices();
  for (size_t s = 0; s < simplices.size(); ++s) {
    std::array<double, 3> w;
    if (inside(static_cast<int>(s), x, y, &w)) {
      out.simplex = static_cast<int>(s);
      out.count = simplices[s].size;
      out.cams = simplices[s].cams;
      out.weight = w;
      return out;
    }
  }
  return out;
}

size_t FragmentPlan::pixel_count() const {
  size_t n = 0;
  for (const auto& s : row_spans) n += static_cast<size_t>(s[1] - s[0]);
  return n;
}

namespace {

using Polygon = std::vector<cv::Vec2d>;

// Sutherland-Hodgman against h(p) >= 0.
Polygon clip(const Polygon& poly, const PixelForm& h) {
  if (h.a == 0 && h.b == 0) return h.c >= 0 ? poly : Polygon{};
  Polygon out;
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
  return out;
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

// Output pixels [x0, x1) x [y0, y1) focused through plane `plane`.
struct Region {
  int x0, y0, x1, y1, plane;
};

// Regions of one plane each: the whole frame, or per tile row the maximal
// horizontal stretches of tiles that share a plane (ViewGeometry::
// layer_plane: layer 1 just the two-plane tiles).
std::vector<Region> focal_regions(const ViewGeometry& g, int layer) {
  const int W = g.width(), H = g.height();
  const FocalSurface& fs = g.request().surface;
  const bool two = fs.two_planes();
  if (layer == 1 && !two) return {};
  if (fs.empty()) return {{0, 0, W, H, 0}};
  std::vector<Region> out;
  std::vector<int> row(fs.cols);
  for (int r = 0; r < fs.rows; ++r) {
    const int y0 = r * fs.tile, y1 = std::min(H, y0 + fs.tile);
    for (int c = 0; c < fs.cols; ++c)
      row[c] = two ? g.layer_plane(layer, r * fs.cols + c) : fs.plane_of[r * fs.cols + c];
    for (int c = 0; c < fs.cols;) {
      const int p = row[c];
      int e = c + 1;
      while (e < fs.cols && row[e] == p) ++e;
      if (p >= 0) out.push_back({c * fs.tile, y0, std::min(W, e * fs.tile), y1, p});
      c = e;
    }
  }
  return out;
}

// The parts of the camera plane's simplices that hold camera `index`, as
// polygons of output pixels: they do not depend on the focal plane.
std::vector<Part> camera_parts(const ViewGeometry& g, int index) {
  const Rig& rig = g.rig();
  const int W = g.width(), H = g.height();
  std::vector<Part> parts;
  const Polygon frame = {{-0.5, -0.5}, {W - 0.5, -0.5}, {W - 0.5, H - 0.5}, {-0.5, H - 0.5}};
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
      Polygon base = frame;
      if (!single) {
        base = clip(base, g.camera_plane_denominator() * sd);
        for (int j = 0; j < sx.size && !base.empty(); ++j)
          base = clip(base, (j == slot ? slot_facet : g.facet_form(sx.facet[j], sx.sign[j])) * sd);
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
                          const std::vector<Region>& regions, int layer) {
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

  for (const Region& reg : regions) {
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
      Polygon base = part.base;
      if (!whole) {
        base = clip(base, {1, 0, 0.5 - reg.x0});
        if (base.size() >= 3) base = clip(base, {-1, 0, reg.x1 - 0.5});
        if (base.size() >= 3) base = clip(base, {0, 1, 0.5 - reg.y0});
        if (base.size() >= 3) base = clip(base, {0, -1, reg.y1 - 0.5});
        if (base.size() < 3) continue;
      }
      // ... times pieces of the focal plane's orientation.
      for (int sf : {1, -1}) {
        if (g.focal_at_infinity(fp) && sf < 0) break;
        Polygon poly = base;
        if (!g.focal_at_infinity(fp)) poly = clip(poly, g.focal_denominator(fp) * sf);
        if (poly.size() >= 3) poly = clip(poly, zc * sf);
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
  // Sort by (y, x0): rows by counting, each row's few runs by insertion.
  {
    std::vector<int> start(H + 1, 0);
    for (const Run& r : plan.runs) ++start[r.y + 1];
    for (int y = 0; y < H; ++y) start[y + 1] += start[y];
    std::vector<Run> sorted(plan.runs.size());
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (const Run& r : plan.runs) sorted[fill[r.y]++] = r;
    for (int y = 0; y < H; ++y)
      for (int k = start[y] + 1; k < start[y + 1]; ++k)
        for (int j = k; j > start[y] && sorted[j].x0 < sorted[j - 1].x0; --j)
          std::swap(sorted[j], sorted[j - 1]);
    plan.runs = std::move(sorted);
  }
  if (plan.runs.empty()) return plan;
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
  plan.row_spans.assign(plan.rect.height, {0, 0});
  std::vector<bool> seen(plan.rect.height, false);
  for (const Run& r : plan.runs) {
    auto& span = plan.row_spans[r.y - ry0];
    if (!seen[r.y - ry0]) {
      span = {r.x0, r.x1};
      seen[r.y - ry0] = true;
    } else {
      span[0] = std::min(span[0], r.x0);
      span[1] = std::max(span[1], r.x1);
    }
  }
  for (int k = 0; k < plan.rect.height; ++k)
    if (!seen[k]) plan.row_spans[k] = {plan.rect.x, plan.rect.x};
  return plan;
}

}  // namespace

FragmentPlan plan_fragment(const ViewGeometry& g, int index, int layer) {
  const std::vector<Region> regions = focal_regions(g, layer);
  return plan_regions(g, index, regions.empty() ? std::vector<Part>{} : camera_parts(g, index),
                      regions, layer);
}

std::array<FragmentPlan, 2> plan_fragment_layers(const ViewGeometry& g, int index) {
  const std::vector<Part> parts = camera_parts(g, index);
  return {plan_regions(g, index, parts, focal_regions(g, 0), 0),
          plan_regions(g, index, parts, focal_regions(g, 1), 1)};
}

}  // namespace lf
