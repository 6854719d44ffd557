// All levels in one weighted QP (Raiola 2020, stack S1); mirrors
// lab/controller/hierarchy/weighted.py.
#include <algorithm>
#include <limits>

#include "hierarchy/problem.hpp"
#include "hierarchy/qp.hpp"

namespace lab {
namespace {
constexpr double kRegularization = 1e-9;  // times the lightest level weight
constexpr double kBoundTol = 1e-9;        // a lower bound above an upper one by more: no x

/// Whether rows with a single nonzero (bounds on one entry of x: normal forces, joint
/// accelerations) contradict each other. eiquadprog cycles without end between its steps 2 and
/// 2a on such a pair instead of calling the problem infeasible (tests/test_faults.py).
bool contradictory_bounds(const Eigen::MatrixXd& C, const Eigen::VectorXd& d) {
  const double inf = std::numeric_limits<double>::infinity();
  Eigen::VectorXd lower = Eigen::VectorXd::Constant(C.cols(), -inf);
  Eigen::VectorXd upper = Eigen::VectorXd::Constant(C.cols(), inf);
  for (Eigen::Index i = 0; i < C.rows(); ++i) {
    Eigen::Index column = -1, nonzeros = 0;
    for (Eigen::Index j = 0; j < C.cols() && nonzeros < 2; ++j)
      if (C(i, j) != 0.0) column = j, ++nonzeros;
    if (nonzeros != 1) continue;
    const double a = C(i, column), bound = d(i) / a;  // a x_j <= d_i
    if (a > 0.0)
      upper(column) = std::min(upper(column), bound);
    else
      lower(column) = std::max(lower(column), bound);
  }
  return ((lower - upper).array() > kBoundTol).any();
}
}  // namespace

void solve_weighted(const HierarchyProblem& problem, HierarchySolution& out) {
  // The QP's matrices, kept from tick to tick (one set per thread, as the solver's).
  thread_local Eigen::MatrixXd H, C;
  thread_local Eigen::VectorXd g, d, rows;
  out.ok = false;
  out.message.clear();
  out.residuals.clear();
  LevelClock clock(out.level_seconds, problem.levels.size());
  const Eigen::Index nx = problem.dynamics_A.cols();
  double lightest = 1.0;
  Eigen::Index inequalities = 0;
  if (!problem.levels.empty()) {
    lightest = problem.levels.front().weight;
    for (const Level& level : problem.levels) {
      lightest = std::min(lightest, level.weight);
      inequalities += level.d.size();
    }
  }
  // min sum_r w_r ||A_r x - b_r||^2 + eps ||x||^2, dynamics exact, every C_r x <= d_r.
  H.setZero(nx, nx);
  H.diagonal().setConstant(kRegularization * lightest);
  g.setZero(nx);
  C.resize(inequalities, nx);
  d.resize(inequalities);
  Eigen::Index row = 0;
  for (const Level& level : problem.levels) {
    // H is symmetric: the lower triangle's rank update only, mirrored below.
    H.selfadjointView<Eigen::Lower>().rankUpdate(level.A.transpose(), level.weight);
    g.noalias() -= level.weight * level.A.transpose() * level.b;
    C.middleRows(row, level.d.size()) = level.C;
    d.segment(row, level.d.size()) = level.d;
    row += level.d.size();
  }
  H.triangularView<Eigen::StrictlyUpper>() = H.transpose();
  out.levels.assign(problem.levels.size(), LevelStatus::qp);
  out.qp_solves = 1;
  const bool bounds_conflict = contradictory_bounds(C, d);
  out.ok = !bounds_conflict && solve_qp(H, g, C, d, problem.dynamics_A, problem.dynamics_b, out.x);
  if (!out.ok) {
    out.message = bounds_conflict
                      ? "the weighted QP is infeasible: a lower bound on x exceeds its upper bound"
                      : "eiquadprog found no solution of the weighted QP";
    out.x.setZero(nx);
  }
  if (!problem.levels.empty()) clock.lap(0);  // one QP for all levels: charged to the first
  for (const Level& level : problem.levels) {
    if (!level.b.size()) {
      out.residuals.push_back(0.0);
      continue;
    }
    rows = level.b;
    rows.noalias() -= level.A * out.x;
    out.residuals.push_back(rows.norm());
  }
}

HierarchySolution solve_weighted(const HierarchyProblem& problem) {
  HierarchySolution out;
  solve_weighted(problem, out);
  return out;
}

}  // namespace lab
