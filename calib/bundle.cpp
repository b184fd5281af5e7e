#include "calib/bundle.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "calib/reprojection_error.h"

namespace lf::calib {

BundleProblem read_bal(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("read_bal: cannot open '" + path + "'");
  return read_bal(in, path);
}

BundleProblem read_bal(std::istream& in, const std::string& path) {
  BundleProblem p;
  size_t nobs = 0;
  auto fail = [&](const std::string& what) -> void {
    throw std::runtime_error("read_bal: " + path + ": " + what);
  };
  if (!(in >> p.num_cameras >> p.num_points >> nobs) || p.num_cameras <= 0 || p.num_points <= 0 ||
      nobs == 0 || nobs > 100000000)
    fail("bad header (expected: cameras points observations, all > 0)");
  // Grow as data arrives: the header's counts are not trusted for allocation
  // (a 3-number header could otherwise ask for gigabytes).
  constexpr size_t kReserveMax = 1 << 16;
  p.observations.reserve(std::min<size_t>(nobs, kReserveMax));
  for (size_t i = 0; i < nobs; ++i) {
    BundleProblem::Observation o;
    if (!(in >> o.camera >> o.point >> o.x >> o.y))
      fail("observation " + std::to_string(i) + " is truncated or not numeric");
    if (o.camera < 0 || o.camera >= p.num_cameras || o.point < 0 || o.point >= p.num_points)
      fail("observation " + std::to_string(i) + " names camera " + std::to_string(o.camera) +
           " / point " + std::to_string(o.point) + ", out of range");
    if (!std::isfinite(o.x) || !std::isfinite(o.y))
      fail("observation " + std::to_string(i) + " is not finite");
    p.observations.push_back(o);
  }
  auto read_block = [&](std::vector<double>& v, size_t n, const char* what) {
    v.reserve(std::min<size_t>(n, kReserveMax));
    for (size_t i = 0; i < n; ++i) {
      double x;
      if (!(in >> x) || !std::isfinite(x)) fail(std::string(what) + " truncated or not finite");
      v.push_back(x);
    }
  };
  read_block(p.cameras, 9 * static_cast<size_t>(p.num_cameras), "camera parameters");
  read_block(p.points, 3 * static_cast<size_t>(p.num_points), "point coordinates");
  return p;
}

BundleReport bundle_adjust(BundleProblem& p, const BundleOptions& opt) {
  if (p.cameras.size() != 9 * static_cast<size_t>(p.num_cameras) ||
      p.points.size() != 3 * static_cast<size_t>(p.num_points))
    throw std::invalid_argument("bundle_adjust: parameter arrays do not match the counts");
  ceres::Problem problem;
  for (const auto& o : p.observations) {
    ceres::CostFunction* cost = BalReprojectionError::Create(o.x, o.y, p.bal_sign);
    ceres::LossFunction* loss = opt.huber_px > 0 ? new ceres::HuberLoss(opt.huber_px) : nullptr;
    problem.AddResidualBlock(cost, loss, &p.cameras[9 * static_cast<size_t>(o.camera)],
                             &p.points[3 * static_cast<size_t>(o.point)]);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::SPARSE_SCHUR;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.max_num_iterations = opt.max_iterations;
  so.num_threads = std::max(1, opt.threads);
  so.minimizer_progress_to_stdout = opt.progress;
  auto* ordering = new ceres::ParameterBlockOrdering;
  for (int i = 0; i < p.num_points; ++i)
    ordering->AddElementToGroup(&p.points[3 * static_cast<size_t>(i)], 0);
  for (int i = 0; i < p.num_cameras; ++i)
    ordering->AddElementToGroup(&p.cameras[9 * static_cast<size_t>(i)], 1);
  so.linear_solver_ordering.reset(ordering);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  BundleReport r;
  r.initial_cost = summary.initial_cost;
  r.final_cost = summary.final_cost;
  const double n = 2.0 * static_cast<double>(p.observations.size());
  r.initial_rms_px = std::sqrt(2 * summary.initial_cost / n);  // robustified if huber_px > 0
  double plain = summary.final_cost;
  if (opt.huber_px > 0) {  // the RMS of the residuals themselves
    ceres::Problem::EvaluateOptions eo;
    eo.apply_loss_function = false;
    problem.Evaluate(eo, &plain, nullptr, nullptr, nullptr);
  }
  r.final_rms_px = std::sqrt(2 * plain / n);
  r.iterations = static_cast<int>(summary.iterations.size()) - 1;
  r.converged = summary.termination_type == ceres::CONVERGENCE;
  r.summary = summary.BriefReport();
  if (!summary.IsSolutionUsable())
    throw std::runtime_error("bundle_adjust: Ceres failed: " + summary.message);
  return r;
}

}  // namespace lf::calib
