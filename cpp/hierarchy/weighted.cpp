// All levels in one weighted QP (Raiola 2020, stack S1); mirrors
// lab/controller/hierarchy/weighted.py.
#include <algorithm>

#include "hierarchy/problem.hpp"
#include "hierarchy/qp.hpp"

namespace lab {
namespace {
constexpr double kRegularization = 1e-9;  // times the lightest level weight
}  // namespace

HierarchySolution solve_weighted(const HierarchyProblem& problem) {
  HierarchySolution out;
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
  Eigen::MatrixXd H = kRegularization * lightest * Eigen::MatrixXd::Identity(nx, nx);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(nx);
  Eigen::MatrixXd C(inequalities, nx);
  Eigen::VectorXd d(inequalities);
  Eigen::Index row = 0;
  for (const Level& level : problem.levels) {
    H.noalias() += level.weight * level.A.transpose() * level.A;
    g.noalias() -= level.weight * level.A.transpose() * level.b;
    C.middleRows(row, level.d.size()) = level.C;
    d.segment(row, level.d.size()) = level.d;
    row += level.d.size();
  }
  out.levels.assign(problem.levels.size(), LevelStatus::qp);
  out.qp_solves = 1;
  out.ok = solve_qp(H, g, C, d, problem.dynamics_A, problem.dynamics_b, out.x);
  if (!out.ok) {
    out.message = "eiquadprog found no solution of the weighted QP";
    out.x = Eigen::VectorXd::Zero(nx);
  }
  if (!problem.levels.empty()) clock.lap(0);  // one QP for all levels: charged to the first
  for (const Level& level : problem.levels)
    out.residuals.push_back(level.b.size() ? (level.A * out.x - level.b).norm() : 0.0);
  return out;
}

}  // namespace lab
