#include "calib/selfcal.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <sstream>
#include <stdexcept>

#include "calib/reprojection_error.h"
#include "lf/geometry/projection.h"
#include "lf/quality/synthetic.h"

namespace lf::calib {

namespace {

struct Pose {
  cv::Matx33d R = cv::Matx33d::eye();
  cv::Vec3d t;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Prior on a camera's intrinsics around the Zhang camera's.
struct IntrinsicsPrior {
  IntrinsicsPrior(const Intrinsics& z, double sf, double sk) : z(z), sf(sf), sk(sk) {}
  template <typename T>
  bool operator()(const T* intr, T* r) const {
    r[0] = (intr[0] - T(z.fx)) / T(sf);
    r[1] = (intr[1] - T(z.k1)) / T(sk);
    r[2] = (intr[2] - T(z.k2)) / T(sk);
    return true;
  }
  Intrinsics z;
  double sf, sk;
};

std::array<double, 6> to_block(const Pose& p) {
  cv::Vec3d aa;
  cv::Rodrigues(cv::Mat(p.R), aa);
  return {aa[0], aa[1], aa[2], p.t[0], p.t[1], p.t[2]};
}
Pose from_block(const std::array<double, 6>& b) {
  Pose p;
  cv::Rodrigues(cv::Vec3d(b[0], b[1], b[2]), p.R);
  p.t = {b[3], b[4], b[5]};
  return p;
}

// Linear triangulation from normalized observations in several views; false
// if a view sees it behind or off by more than `thr` (normalized units).
bool triangulate(const std::vector<Pose>& poses, const std::vector<int>& cams,
                 const std::vector<cv::Vec2d>& xs, double thr, cv::Vec3d& X) {
  if (cams.size() < 2) return false;
  cv::Mat A(static_cast<int>(2 * cams.size()), 4, CV_64F);
  for (size_t k = 0; k < cams.size(); ++k) {
    const Pose& p = poses[cams[k]];
    for (int j = 0; j < 4; ++j) {
      const double P0 = j < 3 ? p.R(0, j) : p.t[0], P1 = j < 3 ? p.R(1, j) : p.t[1],
                   P2 = j < 3 ? p.R(2, j) : p.t[2];
      A.at<double>(static_cast<int>(2 * k), j) = xs[k][0] * P2 - P0;
      A.at<double>(static_cast<int>(2 * k + 1), j) = xs[k][1] * P2 - P1;
    }
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(A, w, u, vt);
  const double h = vt.at<double>(3, 3);
  if (std::abs(h) < 1e-12) return false;
  X = {vt.at<double>(3, 0) / h, vt.at<double>(3, 1) / h, vt.at<double>(3, 2) / h};
  for (size_t k = 0; k < cams.size(); ++k) {
    const Pose& p = poses[cams[k]];
    const cv::Vec3d P = p.R * X + p.t;
    if (P[2] <= 0) return false;
    if (cv::norm(cv::Vec2d(P[0] / P[2], P[1] / P[2]) - xs[k]) > thr) return false;
  }
  return true;
}

// Rows and columns from the camera centres in the reference camera's frame
// (its x and y axes run along the grid): coordinates cluster where the gaps
// between sorted values exceed half the pitch.
void assign_grid(Rig& rig, double pitch, std::vector<std::string>& warnings) {
  const int n = static_cast<int>(rig.cameras.size());
  auto clusters = [&](int axis, std::vector<int>& label) {
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    auto coord = [&](int i) { return rig.cameras[i].center()[axis]; };
    std::sort(order.begin(), order.end(), [&](int x, int y) { return coord(x) < coord(y); });
    label.assign(n, 0);
    int k = 0;
    for (int i = 1; i < n; ++i) {
      if (coord(order[i]) - coord(order[i - 1]) > 0.5 * pitch) ++k;
      label[order[i]] = k;
    }
    return k + 1;
  };
  std::vector<int> row, col;
  const int rows = clusters(1, row), cols = clusters(0, col);
  std::vector<int> cells(static_cast<size_t>(rows) * cols, -1);
  for (int i = 0; i < n; ++i) {
    int& cell = cells[static_cast<size_t>(row[i]) * cols + col[i]];
    if (cell >= 0) {
      warnings.push_back("cameras " + std::to_string(rig.cameras[cell].id) + " and " +
                         std::to_string(rig.cameras[i].id) +
                         " fall into the same grid cell: no grid topology written");
      return;
    }
    cell = i;
  }
  rig.grid.rows = rows;
  rig.grid.cols = cols;
  rig.grid.cells = cells;
}

}  // namespace

namespace {

// Self-calibration in named stages (the members are what the stages hand on).
class SelfCalibration {
 public:
  SelfCalibration(const std::vector<Camera>& cameras, int zc, const Intrinsics& zhang,
                  const std::vector<PointObservation>& obs, const SelfCalOptions& o)
      : cameras(cameras), zc(zc), zhang(zhang), obs(obs), o(o) {}

  SelfCalResult run() {
    prepare();
    if (!initial_pair() || !register_cameras()) return res;
    refine();
    if (!uncertainties()) return res;
    output();
    res.log = log.str();
    return res;
  }

 private:
  // Checks the input; sizes the result; normalized, undistorted observations
  // with the Zhang camera's intrinsics.
  void prepare() {
    nc = static_cast<int>(cameras.size());
    if (nc < 2) throw std::invalid_argument("self_calibrate: need at least 2 cameras");
    if (zc < 0 || zc >= nc)
      throw std::invalid_argument("self_calibrate: zhang_camera out of range");
    if (obs.empty()) throw std::invalid_argument("self_calibrate: no observations");
    np = 0;
    for (const auto& ob : obs) {
      if (ob.camera < 0 || ob.camera >= nc || ob.point < 0)
        throw std::invalid_argument("self_calibrate: observation with camera " +
                                    std::to_string(ob.camera) + ", point " +
                                    std::to_string(ob.point) + " out of range");
      if (!std::isfinite(ob.pixel[0]) || !std::isfinite(ob.pixel[1]))
        throw std::invalid_argument("self_calibrate: non-finite observation");
      np = std::max(np, ob.point + 1);
    }
    res.outlier.assign(obs.size(), false);
    res.registered.assign(nc, false);
    res.points.assign(np, cv::Vec3d());
    res.point_valid.assign(np, false);
    res.camera_rms_px.assign(nc, 0);
    res.camera_observations.assign(nc, 0);
    res.f_sigma.assign(nc, -1);
    res.principal_point_sigma.assign(nc, -1);
    res.intrinsics_sigma.assign(nc, cv::Vec3d(-1, -1, -1));
    res.rotation_sigma_deg.assign(nc, -1);
    res.translation_sigma.assign(nc, -1);
    // Normalized, undistorted observations with the Zhang camera's intrinsics.
    xn.assign(obs.size(), cv::Vec2d());
    usable.assign(obs.size(), true);
    at.assign(nc, std::vector<int>(np, -1));  // camera, point -> obs
    for (size_t i = 0; i < obs.size(); ++i) {
      const auto u = undistort_normalized(zhang, {(obs[i].pixel[0] - zhang.cx) / zhang.fx,
                                                  (obs[i].pixel[1] - zhang.cy) / zhang.fy});
      if (!u || at[obs[i].camera][obs[i].point] >= 0) {
        usable[i] = false;  // not invertible, or a second spot for the same instant
        continue;
      }
      xn[i] = *u;
      at[obs[i].camera][obs[i].point] = static_cast<int>(i);
    }
    thr = o.ransac_px / zhang.fx;
  }

  // Marks the result degenerate (no rig) and says why.
  bool degenerate(const std::string& why) {
    res.degenerate = true;
    res.degenerate_reason = why;
    log << "DEGENERATE: " << why << "\n";
    res.log = log.str();
    return false;
  }

  // The initial pair: many common points, wide parallax; relative pose from
  // the essential matrix; first triangulation and bundle adjustment.
  bool initial_pair() {
    double best = 0;
    for (int i = 0; i < nc; ++i)
      for (int j = i + 1; j < nc; ++j) {
        std::vector<double> disp;
        for (int p = 0; p < np; ++p)
          if (at[i][p] >= 0 && at[j][p] >= 0) disp.push_back(cv::norm(xn[at[i][p]] - xn[at[j][p]]));
        if (static_cast<int>(disp.size()) < o.min_points) continue;
        const double score = disp.size() * median(disp);
        if (score > best) best = score, a = i, b = j;
      }
    if (a < 0)
      return degenerate("no camera pair shares " + std::to_string(o.min_points) +
                        " light positions (too few points, or tracks not overlapping)");
    std::vector<cv::Point2d> pa, pb;
    std::vector<int> common;
    for (int p = 0; p < np; ++p)
      if (at[a][p] >= 0 && at[b][p] >= 0) {
        pa.emplace_back(xn[at[a][p]][0], xn[at[a][p]][1]);
        pb.emplace_back(xn[at[b][p]][0], xn[at[b][p]][1]);
        common.push_back(p);
      }
    cv::Mat emask, hmask;
    const cv::Mat E =
        cv::findEssentialMat(pa, pb, 1.0, cv::Point2d(0, 0), cv::RANSAC, 0.9999, thr, emask);
    if (E.empty() || E.rows != 3) return degenerate("no essential matrix for the initial pair");
    cv::findHomography(pa, pb, cv::RANSAC, thr, hmask);
    const int e_in = cv::countNonZero(emask), h_in = hmask.empty() ? 0 : cv::countNonZero(hmask);
    log << "initial pair: cameras " << cameras[a].id << " and " << cameras[b].id << ", "
        << pa.size() << " common points, essential inliers " << e_in << ", homography inliers "
        << h_in << "\n";
    if (h_in >= 0.9 * e_in)
      return degenerate(
          "the initial pair's tracks fit a homography as well as an essential matrix (" +
          std::to_string(h_in) + " vs " + std::to_string(e_in) +
          " inliers): the light moved in one plane, or there is no parallax; sweep it through "
          "depth");
    cv::Mat Rm, tm;
    cv::recoverPose(E, pa, pb, Rm, tm, 1.0, cv::Point2d(0, 0), emask);
    poses.assign(nc, Pose());
    poses[b].R = cv::Matx33d(Rm);
    poses[b].t = cv::Vec3d(tm);
    res.registered[a] = res.registered[b] = true;
    triangulate_all();
    refine_structure(a);
    return true;
  }

  // Triangulates every untriangulated point seen by two registered cameras,
  // dropping the view that disagrees most until the rest agree.
  int triangulate_all() {
    int added = 0;
    for (int p = 0; p < np; ++p) {
      if (res.point_valid[p]) continue;
      std::vector<int> cams;
      std::vector<cv::Vec2d> xs;
      for (int c = 0; c < nc; ++c)
        if (res.registered[c] && at[c][p] >= 0 && !res.outlier[at[c][p]])
          cams.push_back(c), xs.push_back(xn[at[c][p]]);
      cv::Vec3d X;
      while (cams.size() >= 2) {
        if (triangulate(poses, cams, xs, thr, X)) {
          res.points[p] = X;
          res.point_valid[p] = true;
          ++added;
          break;
        }
        // Drop the view that disagrees most with the others' estimate.
        size_t worst = 0;
        double werr = -1;
        for (size_t k = 0; k < cams.size(); ++k) {
          std::vector<int> c2 = cams;
          std::vector<cv::Vec2d> x2 = xs;
          c2.erase(c2.begin() + static_cast<long>(k));
          x2.erase(x2.begin() + static_cast<long>(k));
          cv::Vec3d Y;
          if (c2.size() >= 2 && triangulate(poses, c2, x2, 1e9, Y)) {
            const cv::Vec3d P = poses[cams[k]].R * Y + poses[cams[k]].t;
            const double e = P[2] > 0 ? cv::norm(cv::Vec2d(P[0] / P[2], P[1] / P[2]) - xs[k]) : 1e9;
            if (e > werr) werr = e, worst = k;
          }
        }
        cams.erase(cams.begin() + static_cast<long>(worst));
        xs.erase(xs.begin() + static_cast<long>(worst));
      }
    }
    return added;
  }

  // Bundle adjustment of poses and points (intrinsics fixed, normalized
  // observations scaled to pixels), Huber loss; camera `fixed` held.
  void refine_structure(int fixed) {
    ceres::Problem pr;
    std::vector<std::array<double, 6>> blocks(nc);
    for (int c = 0; c < nc; ++c) blocks[c] = to_block(poses[c]);
    std::array<double, 3> pinhole = {zhang.fx, 0, 0};  // normalized data: no distortion
    std::array<double, 2> centre = {0, 0};
    for (size_t i = 0; i < obs.size(); ++i) {
      const int c = obs[i].camera, p = obs[i].point;
      if (!usable[i] || res.outlier[i] || !res.registered[c] || !res.point_valid[p]) continue;
      const cv::Vec2d px(xn[i][0] * zhang.fx, xn[i][1] * zhang.fx);
      pr.AddResidualBlock(ReprojectionError::Create(px[0], px[1]), new ceres::HuberLoss(o.huber_px),
                          blocks[c].data(), pinhole.data(), centre.data(), res.points[p].val);
      pr.SetParameterBlockConstant(pinhole.data());
      pr.SetParameterBlockConstant(centre.data());
    }
    if (pr.NumResidualBlocks() == 0) return;
    pr.SetParameterBlockConstant(blocks[fixed].data());
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::SPARSE_SCHUR;
    so.max_num_iterations = 50;
    so.num_threads = o.threads;
    ceres::Solver::Summary s;
    ceres::Solve(so, &pr, &s);
    for (int c = 0; c < nc; ++c)
      if (res.registered[c]) poses[c] = from_block(blocks[c]);
  }

  // Registers the other cameras by PnP, then checks what was reconstructed
  // (enough points, not one plane, tracks covering the images).
  bool register_cameras() {
    for (int round = 0;; ++round) {
      int next = -1, most = 0;
      for (int c = 0; c < nc; ++c) {
        if (res.registered[c]) continue;
        int n = 0;
        for (int p = 0; p < np; ++p) n += at[c][p] >= 0 && res.point_valid[p];
        if (n > most) most = n, next = c;
      }
      if (next < 0 || most < o.min_camera_points) break;
      std::vector<cv::Point3d> X;
      std::vector<cv::Point2d> x;
      std::vector<int> which;
      for (int p = 0; p < np; ++p)
        if (at[next][p] >= 0 && res.point_valid[p]) {
          X.emplace_back(res.points[p][0], res.points[p][1], res.points[p][2]);
          x.emplace_back(xn[at[next][p]][0], xn[at[next][p]][1]);
          which.push_back(at[next][p]);
        }
      cv::Mat rvec, tvec;
      std::vector<int> inl;
      const bool ok = cv::solvePnPRansac(X, x, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec,
                                         false, 500, thr, 0.999, inl, cv::SOLVEPNP_EPNP);
      if (!ok || static_cast<int>(inl.size()) < o.min_camera_points) {
        res.warnings.push_back("camera " + std::to_string(cameras[next].id) +
                               ": PnP failed; not registered");
        at[next].assign(np, -1);  // do not try again
        continue;
      }
      std::vector<cv::Point3d> Xi;
      std::vector<cv::Point2d> xi;
      for (int k : inl) Xi.push_back(X[k]), xi.push_back(x[k]);
      cv::solvePnP(Xi, xi, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, true,
                   cv::SOLVEPNP_ITERATIVE);
      cv::Matx33d R;
      cv::Rodrigues(rvec, R);
      poses[next].R = R;
      poses[next].t = cv::Vec3d(tvec);
      res.registered[next] = true;
      triangulate_all();
      if (round % 8 == 7) refine_structure(a);
    }
    refine_structure(a);
    nreg = 0, npts = 0;
    for (int c = 0; c < nc; ++c) nreg += res.registered[c];
    for (int p = 0; p < np; ++p) npts += res.point_valid[p];
    log << "registered " << nreg << " of " << nc << " cameras, " << npts << " of " << np
        << " light positions triangulated\n";
    for (int c = 0; c < nc; ++c)
      if (!res.registered[c])
        res.warnings.push_back("camera " + std::to_string(cameras[c].id) + " (" + cameras[c].name +
                               ") sees too few light positions: not calibrated");
    if (npts < o.min_points)
      return degenerate("only " + std::to_string(npts) + " light positions reconstructed (need " +
                        std::to_string(o.min_points) + ")");
    {  // The light swept in one plane (caught late if the pair check passed).
      cv::Mat pts(npts, 3, CV_64F);
      int k = 0;
      for (int p = 0; p < np; ++p) {
        if (!res.point_valid[p]) continue;
        for (int j = 0; j < 3; ++j) pts.at<double>(k, j) = res.points[p][j];
        ++k;
      }
      cv::PCA pca(pts, cv::Mat(), cv::PCA::DATA_AS_ROW);
      const double ratio = std::sqrt(pca.eigenvalues.at<double>(2) / pca.eigenvalues.at<double>(0));
      log << "light positions: thinnest / widest extent " << ratio << "\n";
      if (ratio < 0.02) return degenerate("the light positions lie in one plane");
    }

    {  // Coverage: the convex hull of each camera's observations, as a fraction
       // of its image (distortion is only pinned where the light went).
      std::vector<double> cover(nc, 0);
      for (int c = 0; c < nc; ++c) {
        if (!res.registered[c]) continue;
        std::vector<cv::Point2f> pts;
        for (int p = 0; p < np; ++p)
          if (at[c][p] >= 0 && res.point_valid[p])
            pts.emplace_back(static_cast<float>(obs[at[c][p]].pixel[0]),
                             static_cast<float>(obs[at[c][p]].pixel[1]));
        if (pts.size() < 3) continue;
        std::vector<cv::Point2f> hull;
        cv::convexHull(pts, hull);
        cover[c] =
            cv::contourArea(hull) / (static_cast<double>(cameras[c].width) * cameras[c].height);
        if (cover[c] < 0.25)
          res.warnings.push_back("camera " + std::to_string(cameras[c].id) +
                                 ": the light covered " +
                                 std::to_string(static_cast<int>(100 * cover[c])) +
                                 " % of the image (distortion poorly pinned)");
      }
      std::vector<double> reg;
      for (int c = 0; c < nc; ++c)
        if (res.registered[c]) reg.push_back(cover[c]);
      const double med = median(reg);
      log << "image coverage of the tracks: median " << static_cast<int>(100 * med) << " %\n";
      if (med < 0.1)
        return degenerate("the tracks cover a median " +
                          std::to_string(static_cast<int>(100 * med)) +
                          " % of the images: move the light through the whole field of view");
    }
    return true;
  }

  // The refinement problem: poses, intrinsics (shared, or per camera with a
  // prior), principal points (held unless freed), points; gauge fixed.
  void build_problem(ceres::Problem& pr, bool robust, const std::vector<bool>& use,
                     const std::vector<bool>& free_pp) {
    for (size_t i = 0; i < obs.size(); ++i) {
      if (!use[i]) continue;
      const int c = obs[i].camera;
      pr.AddResidualBlock(ReprojectionError::Create(obs[i].pixel[0], obs[i].pixel[1]),
                          robust ? new ceres::HuberLoss(o.huber_px) : nullptr, pblocks[c].data(),
                          iblocks[shared ? 0 : c].data(), ppblocks[c].data(),
                          res.points[obs[i].point].val);
    }
    for (int c = 0; c < nc; ++c)
      if (pr.HasParameterBlock(ppblocks[c].data()) && !free_pp[c])
        pr.SetParameterBlockConstant(ppblocks[c].data());
    if (!shared)
      for (int c = 0; c < nc; ++c)
        if (res.registered[c])
          pr.AddResidualBlock(new ceres::AutoDiffCostFunction<IntrinsicsPrior, 3, 3>(
                                  new IntrinsicsPrior(zhang, o.f_prior * zhang.fx, o.k_prior)),
                              nullptr, iblocks[c].data());
    pr.SetParameterBlockConstant(pblocks[a].data());
    pr.SetManifold(pblocks[far].data(), new ceres::SubsetManifold(6, {3 + comp}));
  }

  // Solves it (into `keep` when given) and records every residual.
  void solve(bool robust, const std::vector<bool>& use, ceres::Problem* keep) {
    ceres::Problem local;
    ceres::Problem& pr = keep ? *keep : local;
    build_problem(pr, robust, use, pp_free);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::SPARSE_SCHUR;
    so.max_num_iterations = 100;
    so.function_tolerance = 1e-10;
    so.num_threads = o.threads;
    ceres::Solver::Summary s;
    ceres::Solve(so, &pr, &s);
    log << (robust ? "refinement (Huber " : "final least squares (") << o.huber_px
        << " px): " << s.BriefReport() << "\n";
    for (size_t i = 0; i < obs.size(); ++i) {
      if (!active[i]) continue;
      const int c = obs[i].camera;
      const ReprojectionError e(obs[i].pixel[0], obs[i].pixel[1]);
      double r[2];
      e(pblocks[c].data(), iblocks[shared ? 0 : c].data(), ppblocks[c].data(),
        res.points[obs[i].point].val, r);
      resid[i] = std::hypot(r[0], r[1]);
    }
  }

  // Refinement: Huber solve, outliers flagged, principal points freed where
  // pinned, final least squares, residual statistics.
  void refine() {
    shared = o.f_prior <= 0;
    pblocks.assign(nc, {});
    iblocks.assign(shared ? 1 : nc, {});
    for (int c = 0; c < nc; ++c) pblocks[c] = to_block(poses[c]);
    for (auto& ib : iblocks) ib = {zhang.fx, zhang.k1, zhang.k2};
    // Gauge: camera a fixed; scale: the largest translation component of the
    // registered camera farthest from a.
    far = b;
    for (int c = 0; c < nc; ++c)
      if (res.registered[c] && cv::norm(poses[c].t) > cv::norm(poses[far].t)) far = c;
    comp = 0;
    for (int j = 1; j < 3; ++j)
      if (std::abs(poses[far].t[j]) > std::abs(poses[far].t[comp])) comp = j;
    active.assign(obs.size(), false);
    for (size_t i = 0; i < obs.size(); ++i)
      active[i] = usable[i] && res.registered[obs[i].camera] && res.point_valid[obs[i].point];
    resid.assign(obs.size(), -1);
    // Principal points: the Zhang camera's, freed per camera only where the
    // data pins them (decided below).
    ppblocks.assign(nc, {zhang.cx, zhang.cy});
    pp_free.assign(nc, false);
    solve(true, active, nullptr);
    // Outliers: residual norm above the threshold (robust sigma from the MAD).
    std::vector<double> comps;
    for (size_t i = 0; i < obs.size(); ++i)
      if (active[i]) comps.push_back(resid[i]);
    // The norm of a 2-D Gaussian error is Rayleigh: median = sigma sqrt(2 ln 2).
    const double sigma = median(comps) / std::sqrt(2 * std::log(2.0));
    cut = o.outlier_px > 0 ? o.outlier_px : std::max(1.5, 5 * sigma);
    inlier = active;
    int nout = 0;
    for (size_t i = 0; i < obs.size(); ++i)
      if (active[i] && resid[i] > cut) inlier[i] = false, res.outlier[i] = true, ++nout;
    log << "outliers: " << nout << " observations with residual > " << cut << " px (robust sigma "
        << sigma << " px)\n";
    {  // Which principal points do the data pin? Covariance with all of them free.
      ceres::Problem test;
      build_problem(test, false, inlier, std::vector<bool>(nc, true));
      ceres::Covariance::Options co;
      co.num_threads = o.threads;
      ceres::Covariance cov(co);
      std::vector<std::pair<const double*, const double*>> blocks;
      for (int c = 0; c < nc; ++c)
        if (res.registered[c]) blocks.emplace_back(ppblocks[c].data(), ppblocks[c].data());
      const bool ok = cov.Compute(blocks, &test);
      std::vector<double> sig;
      int freed = 0;
      for (int c = 0; c < nc && ok; ++c) {
        if (!res.registered[c]) continue;
        double C[4];
        if (!cov.GetCovarianceBlock(ppblocks[c].data(), ppblocks[c].data(), C)) continue;
        res.principal_point_sigma[c] = std::sqrt(std::max({0.0, C[0], C[3]}));
        sig.push_back(res.principal_point_sigma[c]);
        pp_free[c] = o.pin_principal_px > 0 && res.principal_point_sigma[c] < o.pin_principal_px;
        freed += pp_free[c];
      }
      log << "principal points: "
          << (ok ? "sigma with all free: median " + std::to_string(median(sig)) + " px; " +
                       std::to_string(freed) + " pinned (< " + std::to_string(o.pin_principal_px) +
                       " px) and freed, the others held at the Zhang camera's"
                 : std::string("not determined with all free (rank deficient): held"))
          << "\n";
    }
    solve(false, inlier, &final_problem);
    // Residuals after the final solve.
    double se = 0;
    size_t n_in = 0;
    std::vector<double> cam_se(nc, 0);
    for (size_t i = 0; i < obs.size(); ++i) {
      if (!active[i]) continue;
      res.outlier[i] = resid[i] > cut;
      if (res.outlier[i]) continue;
      se += resid[i] * resid[i];
      cam_se[obs[i].camera] += resid[i] * resid[i];
      res.camera_observations[obs[i].camera]++;
      ++n_in;
    }
    res.rms_px = std::sqrt(se / (2.0 * n_in));
    res.residual_px = resid;
    for (int c = 0; c < nc; ++c)
      if (res.camera_observations[c])
        res.camera_rms_px[c] = std::sqrt(cam_se[c] / (2.0 * res.camera_observations[c]));
    const double params =
        6.0 * nreg + 3.0 * npts - 7 + (shared ? 3 : 0) +
        2.0 * static_cast<double>(std::count(pp_free.begin(), pp_free.end(), true));
    res.noise_floor_factor = std::sqrt(std::max(0.0, (2.0 * n_in - params) / (2.0 * n_in)));
    log << "reprojection RMS " << res.rms_px << " px per coordinate over " << n_in
        << " observations (noise floor factor " << res.noise_floor_factor << ")\n";
  }

  // Parameter uncertainties (Ceres covariance); a shared focal length the
  // tracks do not determine is degenerate.
  bool uncertainties() {
    // Parameter uncertainties (Ceres covariance, gauge fixed as above):
    // intrinsics f, k1, k2, and each pose's rotation and translation.
    t_sigma.assign(nc, -1);
    {
      ceres::Covariance::Options co;
      co.num_threads = o.threads;
      ceres::Covariance cov(co);
      std::vector<std::pair<const double*, const double*>> blocks;
      for (auto& ib : iblocks) blocks.emplace_back(ib.data(), ib.data());
      for (int c = 0; c < nc; ++c)
        if (res.registered[c] && c != a) blocks.emplace_back(pblocks[c].data(), pblocks[c].data());
      bool ok = cov.Compute(blocks, &final_problem);
      for (size_t k = 0; k < iblocks.size() && ok; ++k) {
        double C[9];
        ok = cov.GetCovarianceBlock(iblocks[k].data(), iblocks[k].data(), C);
        const cv::Vec3d sd(std::sqrt(std::max(0.0, C[0])), std::sqrt(std::max(0.0, C[4])),
                           std::sqrt(std::max(0.0, C[8])));
        if (shared) {
          res.f_sigma.assign(nc, ok ? sd[0] : -1);
          res.intrinsics_sigma.assign(nc, sd);
        } else {
          res.f_sigma[k] = ok ? sd[0] : -1;
          res.intrinsics_sigma[k] = sd;
        }
      }
      for (int c = 0; c < nc && ok; ++c) {
        if (!res.registered[c]) continue;
        if (c == a) {
          res.rotation_sigma_deg[c] = 0, t_sigma[c] = 0;  // the gauge
          continue;
        }
        double C[36];
        if (!cov.GetCovarianceBlock(pblocks[c].data(), pblocks[c].data(), C)) continue;
        res.rotation_sigma_deg[c] = std::sqrt(std::max(0.0, C[0] + C[7] + C[14])) * 180 / CV_PI;
        t_sigma[c] = std::sqrt(std::max(0.0, C[21] + C[28] + C[35]));
      }
      if (shared) {
        const double rel = res.f_sigma[0] > 0 ? res.f_sigma[0] / iblocks[0][0] : -1;
        log << "shared focal length " << iblocks[0][0] << " px, sigma "
            << (ok ? std::to_string(res.f_sigma[0]) : std::string("undetermined (rank deficient)"))
            << "\n";
        if (!ok || rel > o.max_f_sigma)
          return degenerate(
              "the tracks do not determine the focal length (shared f sigma " +
              (ok ? std::to_string(100 * rel) + " %" : std::string("unbounded")) +
              "): a planar, parallel grid leaves (f, Z) -> (s f, s Z) nearly free; hold the Zhang "
              "camera's intrinsics or give them a prior");
      }
    }
    return true;
  }

  // Output: camera a's frame -> camera zc's frame, scaled to the pitch; grid.
  void output() {
    for (int c = 0; c < nc; ++c) poses[c] = from_block(pblocks[c]);
    const Pose ref = poses[zc];  // camera zc's pose in camera a's frame
    std::vector<cv::Vec3d> centres;
    for (int c = 0; c < nc; ++c)
      if (res.registered[c]) centres.push_back(-(poses[c].R.t() * poses[c].t));
    std::vector<double> nn;
    for (size_t i = 0; i < centres.size(); ++i) {
      double d = 1e300;
      for (size_t j = 0; j < centres.size(); ++j)
        if (i != j) d = std::min(d, cv::norm(centres[i] - centres[j]));
      nn.push_back(d);
    }
    const double s = o.pitch / median(nn);
    for (int c = 0; c < nc; ++c)
      if (t_sigma[c] >= 0) res.translation_sigma[c] = s * t_sigma[c];
    res.rig.name = "self-calibrated";
    for (int c = 0; c < nc; ++c) {
      Camera cam = cameras[c];
      const auto& ib = iblocks[shared ? 0 : c];
      cam.intrinsics = zhang;
      cam.intrinsics.fx = cam.intrinsics.fy = ib[0];
      cam.intrinsics.k1 = ib[1];
      cam.intrinsics.k2 = ib[2];
      cam.intrinsics.cx = ppblocks[c][0];
      cam.intrinsics.cy = ppblocks[c][1];
      // X_zc = R_ref X_a + t_ref; camera c: X_c = R_c X_a + t_c = R_c R_ref^T (X_zc - t_ref) + t_c
      const cv::Matx33d R = poses[c].R * ref.R.t();
      const cv::Vec3d t = poses[c].t - R * ref.t;
      cam.extrinsics.R = R;
      cam.extrinsics.t = s * t;
      if (res.registered[c]) res.rig.cameras.push_back(cam);
    }
    for (int p = 0; p < np; ++p)
      if (res.point_valid[p]) res.points[p] = s * (ref.R * res.points[p] + ref.t);
    assign_grid(res.rig, o.pitch, res.warnings);
    res.rig.finalize();
    log << "topology: "
        << (res.rig.grid.empty() ? std::string("no regular grid")
                                 : std::to_string(res.rig.grid.rows) + " x " +
                                       std::to_string(res.rig.grid.cols) + " grid")
        << "\n";
  }

  // Input.
  const std::vector<Camera>& cameras;
  const int zc;
  const Intrinsics zhang;
  const std::vector<PointObservation>& obs;
  const SelfCalOptions& o;
  int nc = 0, np = 0;
  SelfCalResult res;
  std::ostringstream log;
  // prepare()
  std::vector<cv::Vec2d> xn;
  std::vector<bool> usable;
  std::vector<std::vector<int>> at;  // camera, point -> observation (-1: none)
  double thr = 0;                    // RANSAC threshold, normalized units
  // initial_pair(), register_cameras()
  int a = -1, b = -1;  // the initial pair; a is the gauge
  std::vector<Pose> poses;
  int nreg = 0, npts = 0;
  // refine()
  bool shared = false;  // one focal length for all
  std::vector<std::array<double, 6>> pblocks;
  std::vector<std::array<double, 3>> iblocks;
  std::vector<std::array<double, 2>> ppblocks;
  std::vector<bool> pp_free;
  int far = 0, comp = 0;  // scale gauge: camera and translation component
  std::vector<bool> active, inlier;
  std::vector<double> resid;
  double cut = 0;
  ceres::Problem final_problem;
  // uncertainties()
  std::vector<double> t_sigma;
};

}  // namespace

SelfCalResult self_calibrate(const std::vector<Camera>& cameras, int zc, const Intrinsics& zhang,
                             const std::vector<PointObservation>& obs, const SelfCalOptions& o) {
  return SelfCalibration(cameras, zc, zhang, obs, o).run();
}

}  // namespace lf::calib
