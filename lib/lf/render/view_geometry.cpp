// ViewGeometry (lib/lf/render/plan.h): the request's homographies, the
// aperture's weight forms and the ULR blending field, per camera.
#include <algorithm>
#include <cmath>
#include <map>

#include "lf/render/plan.h"

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
  std::vector<int> uses(rig.facets().size(), 0);  // 1: a facet on the hull's border
  for (const Simplex& sx : rig.simplices())
    for (int k = 0; k < sx.size; ++k)
      if (sx.facet[k] >= 0) ++uses[sx.facet[k]];
  for (const Simplex& sx : rig.simplices()) {
    if (sx.size != 3) continue;
    bool inside = true, on_border = false;
    for (int k = 0; k < 3; ++k) {
      const double v = rig.facets()[sx.facet[k]](e) * sx.sign[k];
      inside = inside && v >= 0;
      on_border = on_border || (v == 0 && uses[sx.facet[k]] == 1);
    }
    const cv::Vec2d a = pos[sx.cams[0]], b = pos[sx.cams[1]], c = pos[sx.cams[2]];
    if (inside && !on_border) return e;  // the tie rule gives it to one triangle
    if (inside) {
      // Exactly on the hull's border, where the tie rule may perturb it
      // outwards, to no triangle: into this one.
      const cv::Vec2d centre = (a + b + c) * (1.0 / 3.0);
      const double to_centre = cv::norm(centre - e);
      return to_centre > 0 ? e + (centre - e) * (1e-6 * rig.typical_spacing() / to_centre) : e;
    }
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

// Grid cells for four-camera weights (lf/geometry/view.h
// Aperture::kFourCamera): per simplex, the triangle sharing its longest edge
// (its cell's diagonal) when that edge is also the partner's longest and the
// two make a convex cell, else -1 (always -1 on a rig without a grid).
std::vector<int> cell_partners(const Rig& rig) {
  const auto& sx = rig.simplices();
  const auto& pos = rig.plane_positions();
  std::vector<int> partner(sx.size(), -1);
  if (rig.grid.empty()) return partner;  // cells only where the rig is a grid
  std::map<std::pair<int, int>, std::vector<int>> by_edge;
  for (size_t s = 0; s < sx.size(); ++s) {
    if (sx[s].size != 3) continue;
    int best = 0;
    double longest = -1;
    for (int k = 0; k < 3; ++k) {
      const double len = cv::norm(pos[sx[s].cams[k]] - pos[sx[s].cams[(k + 1) % 3]]);
      if (len > longest) longest = len, best = k;
    }
    const int a = sx[s].cams[best], b = sx[s].cams[(best + 1) % 3];
    by_edge[{std::min(a, b), std::max(a, b)}].push_back(static_cast<int>(s));
  }
  auto side = [&](int a, int b, int c) {  // sign of c relative to line ab
    const cv::Vec2d u = pos[b] - pos[a], v = pos[c] - pos[a];
    return u[0] * v[1] - u[1] * v[0];
  };
  for (const auto& [edge, tris] : by_edge) {
    if (tris.size() != 2) continue;
    int third[2] = {-1, -1};
    for (int k = 0; k < 2; ++k)
      for (int c : sx[tris[k]].cams)
        if (c != edge.first && c != edge.second) third[k] = c;
    // A convex cell: each diagonal separates the other's ends.
    if (side(edge.first, edge.second, third[0]) * side(edge.first, edge.second, third[1]) < 0 &&
        side(third[0], third[1], edge.first) * side(third[0], third[1], edge.second) < 0)
      partner[tris[0]] = tris[1], partner[tris[1]] = tris[0];
  }
  return partner;
}

// Barycentric coordinates of p in triangle (a, b, c); false if degenerate.
bool barycentric(const cv::Vec2d& p, const cv::Vec2d& a, const cv::Vec2d& b, const cv::Vec2d& c,
                 std::array<double, 3>& l) {
  const double det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]);
  if (!(std::abs(det) > 0)) return false;
  l[1] = ((p[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (p[1] - a[1])) / det;
  l[2] = ((b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1])) / det;
  l[0] = 1.0 - l[1] - l[2];
  return true;
}

// Four-camera weights at camera-plane point X: the mean of the rig's tent
// and the tent of its cells split along their other diagonals (a triangle
// without a partner: its tent). Adds each camera's weight into w (indexed by
// camera); nothing where X is outside the triangulation.
void four_camera_weights(const Rig& rig, const std::vector<int>& partner, const cv::Vec2d& X,
                         double* w) {
  const auto& sxs = rig.simplices();
  const auto& pos = rig.plane_positions();
  for (size_t s = 0; s < sxs.size(); ++s) {
    const Simplex& sx = sxs[s];
    if (sx.size != 3) continue;
    std::array<double, 3> e;
    double sum = 0;
    bool inside = true;
    for (int k = 0; k < 3; ++k) {
      e[k] = rig.facets()[sx.facet[k]](X) * sx.sign[k];
      inside = inside && e[k] >= 0;
      sum += e[k];
    }
    if (!inside || !(sum > 0)) continue;
    const int p = partner[s];
    const double half = p < 0 ? 1.0 : 0.5;
    for (int k = 0; k < 3; ++k) w[sx.cams[k]] += half * e[k] / sum;
    if (p < 0) return;
    // The other diagonal joins the two triangles' third vertices R and S;
    // X lies in (R, S, P) or (R, S, Q), P and Q the shared diagonal's ends.
    int R = -1, S = -1;
    for (int c : sx.cams)
      if (std::find(sxs[p].cams.begin(), sxs[p].cams.end(), c) == sxs[p].cams.end()) R = c;
    for (int c : sxs[p].cams)
      if (std::find(sx.cams.begin(), sx.cams.end(), c) == sx.cams.end()) S = c;
    std::array<double, 3> best{0, 0, 0};
    int best_end = -1;
    double best_min = -INFINITY;
    for (int c : sx.cams) {
      if (c == R) continue;
      std::array<double, 3> l;
      if (!barycentric(X, pos[R], pos[S], pos[c], l)) continue;
      const double m = std::min({l[0], l[1], l[2]});
      if (m > best_min) best_min = m, best = l, best_end = c;
    }
    if (best_end < 0) {  // a degenerate cell: the tent alone
      for (int k = 0; k < 3; ++k) w[sx.cams[k]] += half * e[k] / sum;
      return;
    }
    const int cams[3] = {R, S, best_end};
    for (int k = 0; k < 3; ++k) w[cams[k]] += half * std::clamp(best[k], 0.0, 1.0);
    return;
  }
}

// The plane of tile `tile` of a non-empty surface in fragment layer `layer`
// (ViewGeometry::layer_plane), given which tiles' second plane is the
// nearer (SurfaceLayout::second_nearer).
int plane_in_layer(const FocalSurface& fs, const std::vector<uint8_t>& second_nearer, int layer,
                   int tile) {
  const int a = fs.plane_of[tile];
  const int b = fs.second_of.empty() ? FocalSurface::kNone : fs.second_of[tile];
  if (b == FocalSurface::kNone) return layer == 0 ? a : -1;
  return (layer == 1) == (second_nearer[tile] != 0) ? b : a;
}

}  // namespace

ViewGeometry::ViewGeometry(const Rig& rig, const ViewRequest& request, int only_camera,
                           std::shared_ptr<const UlrField> ulr,
                           std::shared_ptr<const SurfaceLayout> layout)
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
  if (req_.aperture == Aperture::kUlr || req_.aperture == Aperture::kFourCamera) {
    const int G = kUlrGrid;
    if (ulr && ulr->cols == (v.width + G - 1) / G && ulr->rows == (v.height + G - 1) / G &&
        ulr->cameras == ncam_ &&
        ulr->w.size() == static_cast<size_t>(ulr->cols + 1) * (ulr->rows + 1) * ncam_)
      ulr_ = std::move(ulr);
    else
      ulr_ = compute_ulr();
  }
  const FocalSurface& fs = req_.surface;
  if (layout && layout->width == v.width && layout->height == v.height && layout->cols == fs.cols &&
      layout->rows == fs.rows &&
      layout->second_nearer.size() == (fs.two_planes() ? fs.plane_of.size() : 0))
    layout_ = std::move(layout);
  else
    layout_ = compute_layout();
}

std::shared_ptr<const SurfaceLayout> ViewGeometry::compute_layout() const {
  auto out = std::make_shared<SurfaceLayout>();
  const FocalSurface& fs = req_.surface;
  const VirtualView& v = req_.view;
  const int W = v.width, H = v.height;
  out->width = W;
  out->height = H;
  if (fs.empty()) {
    out->regions[0] = {{0, 0, W, H, 0}};
    return out;
  }
  out->cols = fs.cols;
  out->rows = fs.rows;
  // Two-plane tiles: whether the second plane is the nearer, along the ray
  // of the tile's centre pixel (a plane behind the eye, parallel to the ray
  // or at infinity is infinitely far).
  const bool two = fs.two_planes();
  if (two) {
    const cv::Vec3d E = v.position;
    auto along = [&](const FocalPlane& p, const cv::Vec3d& D) {
      const double t = -(p.n.dot(E) + p.d) / p.n.dot(D);
      return p.at_infinity() || !(t > 0) || !std::isfinite(t) ? INFINITY : t;
    };
    out->second_nearer.assign(fs.plane_of.size(), 0);
    for (int r = 0; r < fs.rows; ++r)
      for (int c = 0; c < fs.cols; ++c) {
        const int t = r * fs.cols + c;
        if (fs.second_of[t] == FocalSurface::kNone) continue;
        const double x = (std::min(W, (c + 1) * fs.tile) + c * fs.tile - 1) * 0.5;
        const double y = (std::min(H, (r + 1) * fs.tile) + r * fs.tile - 1) * 0.5;
        const cv::Vec3d D = ray(x, y);
        out->second_nearer[t] =
            along(fs.planes[fs.second_of[t]], D) < along(fs.planes[fs.plane_of[t]], D) ? 1 : 0;
      }
  }
  // Each layer's regions: per tile row the maximal stretches of tiles that
  // share a plane.
  std::vector<int> row(fs.cols);
  for (int layer = 0; layer < (two ? 2 : 1); ++layer)
    for (int r = 0; r < fs.rows; ++r) {
      const int y0 = r * fs.tile, y1 = std::min(H, y0 + fs.tile);
      for (int c = 0; c < fs.cols; ++c)
        row[c] = plane_in_layer(fs, out->second_nearer, layer, r * fs.cols + c);
      for (int c = 0; c < fs.cols;) {
        const int p = row[c];
        int e = c + 1;
        while (e < fs.cols && row[e] == p) ++e;
        if (p >= 0)
          out->regions[layer].push_back({c * fs.tile, y0, std::min(W, e * fs.tile), y1, p});
        c = e;
      }
    }
  return out;
}

int ViewGeometry::layer_plane(int layer, int tile) const {
  const FocalSurface& fs = req_.surface;
  if (fs.empty()) return layer == 0 ? 0 : -1;
  return plane_in_layer(fs, layout_->second_nearer, layer, tile);
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
  if (req_.aperture == Aperture::kFourCamera) {
    const std::vector<int> partner = cell_partners(rig);
    const CameraPlane& P = rig.plane();
    for (int vy = 0; vy <= field->rows; ++vy)
      for (int vx = 0; vx <= field->cols; ++vx) {
        double* w = &field->w[(static_cast<size_t>(vy) * (field->cols + 1) + vx) * ncam_];
        // The line's camera-plane point (plan.h: X = E_2d - dist D_2d / D_n).
        cv::Vec2d X = eye2d_;
        if (eye_dist_ != 0.0) {
          const cv::Vec3d D = ray(vx * G, vy * G);
          const double dn = D.dot(P.normal);
          if (dn == 0) continue;  // parallel to the plane: not seen
          X = eye2d_ - cv::Vec2d(D.dot(P.u), D.dot(P.v)) * (eye_dist_ / dn);
        }
        if (rig.dimension() == 2) {
          four_camera_weights(rig, partner, X, w);
        } else {  // a 1-D or one-camera rig has no cells: its tent
          const ApertureSample a = locate(vx * G, vy * G);
          for (int k = 0; k < a.count; ++k) w[a.cams[k]] += a.weight[k];
        }
      }
    return field;
  }
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

}  // namespace lf
