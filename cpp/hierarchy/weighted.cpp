// All levels in one weighted QP (Raiola 2020, stack S1); mirrors
// lab/controller/hierarchy/weighted.py.
#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "hierarchy/linalg.hpp"
#include "hierarchy/problem.hpp"
#include "hierarchy/qp.hpp"

namespace lab {
namespace {
constexpr double kRegularization = 1e-9;  // times the lightest level weight
// Level weights down to this span a Hessian DAQP solves to its optimum (below it, as
// hutter_table7's 1e-18, it stops short whichever form it gets).
constexpr double kWellConditionedWeight = 1e-9;

/// The weighted QP over u after the Newton-Euler rows are eliminated with the base block of M
/// (x = x0 + Z u, Z = [-A1^-1 A2; I], the cascade's level 0): DAQP then sees no equality row.
/// The same optimum as with the rows, in 17 instead of 25 us for ANYmal (DAQP's own elimination,
/// a QR, was most of it). Its Hessian and gradient come from each level's A Z,
/// Z^T H Z = sum_r w_r (A_r Z)^T (A_r Z) + eps Z^T Z and Z^T (g + H x0) = sum_r w_r
/// (A_r Z)^T (A_r x0 - b_r) + eps Z^T x0, never forming the full H (fewer and smaller products:
/// the rank update is over u's columns only). Levels of weight 0 add nothing and are skipped.
/// False when the base block is singular or DAQP finds no u.
bool solve_reduced(const HierarchyProblem& problem, double regularization, const Eigen::MatrixXd& C,
                   const Eigen::VectorXd& d, Eigen::VectorXd& x, QpReport& report) {
  thread_local Eigen::MatrixXd Z, S, Hz, Cz, Ab;
  thread_local Eigen::VectorXd x0, gz, dz, u, weighted_residual, root_weight;
  thread_local BaseBlockLU lu;
  thread_local std::vector<std::pair<std::size_t, Eigen::Index>> dense;  // (level, row) in S
  if (!solution_and_null_space_of_leading_block(problem.dynamics_A, problem.dynamics_b, Z, x0, lu))
    return false;
  // Z's lower block is the identity: products with Z take its upper k rows only.
  constexpr Eigen::Index k = kBaseRows;
  const Eigen::Index nu = Z.cols();
  const auto Zt = Z.topRows<k>();
  // S stacks sqrt(eps) Zt and each level's sqrt(w_r) A_r Z: Z^T H Z = S^T S + eps I, one rank
  // update instead of one per level (each sets up its own blocking: most of its cost here). A row
  // that selects one entry of x past the base (zero on the base's columns, one entry a in column
  // j: the posture and force rows) has A Z = a e_j, Z's lower block being the identity: its share
  // is w a^2 on the diagonal and w a (a x0_j - b) in the gradient, and it stays out of S (half of
  // ANYmal's rows).
  Hz.setZero(nu, nu);  // one memset, then the diagonal: setIdentity tests every entry
  Hz.diagonal().setConstant(regularization);
  gz.noalias() = Zt.transpose() * x0.head<k>();
  gz += x0.tail(nu);
  gz *= regularization;
  dense.clear();
  for (std::size_t l = 0; l < problem.levels.size(); ++l) {
    const Level& level = problem.levels[l];
    if (!level.b.size() || level.weight == 0.0) continue;
    const double w = level.weight;
    for (Eigen::Index r = 0; r < level.A.rows(); ++r) {
      const auto entries = level.A.row(r);
      Eigen::Index column = -1;  // the one nonzero entry's (-1: none yet or on the base, -2: two)
      if (entries.head<k>().isZero(0.0)) {
        for (Eigen::Index j = k; j < entries.size(); ++j) {
          if (entries(j) == 0.0) continue;
          column = column < 0 ? j : -2;
          if (column == -2) break;
        }
      }
      if (column < 0) {
        dense.emplace_back(l, r);
        continue;
      }
      const double a = entries(column);
      Hz(column - k, column - k) += w * a * a;
      gz(column - k) += w * a * (a * x0(column) - level.b(r));
    }
  }
  // The other rows' A Z in one product: their base columns gathered (Ab) times Zt, added to
  // their other columns (S's rows below k); then the gradient's share, one product with the
  // weighted residuals at x0, and each row scaled by sqrt(w_r).
  const auto nd = static_cast<Eigen::Index>(dense.size());
  S.resize(k + nd, nu);
  S.topRows<k>() = std::sqrt(regularization) * Zt;
  Ab.resize(nd, k);
  weighted_residual.resize(nd);
  root_weight.resize(nd);
  for (Eigen::Index i = 0; i < nd; ++i) {
    const auto& [l, r] = dense[static_cast<std::size_t>(i)];
    const Level& level = problem.levels[l];
    Ab.row(i) = level.A.row(r).head<k>();
    S.row(k + i) = level.A.row(r).tail(nu);
    weighted_residual(i) = level.weight * (Ab.row(i).dot(x0.head<k>()) - level.b(r));
    root_weight(i) = std::sqrt(level.weight);
  }
  auto SA = S.bottomRows(nd);
  SA.noalias() += Ab.lazyProduct(Zt);  // coefficient-wise: a blocked product costs more at 6 deep
  gz.noalias() += SA.transpose() * weighted_residual;
  SA = root_weight.asDiagonal() * SA;
  Hz.selfadjointView<Eigen::Lower>().rankUpdate(S.transpose());
  Hz.triangularView<Eigen::StrictlyUpper>() = Hz.transpose();
  // Friction, cop and the sole rows are on the forces only: Zt's product only where a row has
  // a base column (none of ANYmal's or Talos's).
  Cz = C.rightCols(nu);
  if (!C.leftCols<k>().isZero(0.0)) Cz.noalias() += C.leftCols<k>() * Zt;
  dz = d;
  dz.noalias() -= C.leftCols<k>() * x0.head<k>();  // x0 is zero past the base
  // A contact out of support carries no force: its columns of u leave every row, so its u
  // (decoupled, u^2 with no gradient: x0's forces are zero) is zero at the optimum. Its
  // curvature is 1, not eps: DAQP's factorization took a 1e-15 pivot (eps times hutter_table7's
  // or Raiola S3's lightest weight) for trouble and stopped 0.4 % above the optimum (ANYmal's
  // trot).
  const Eigen::Index nf = problem.support.size();
  for (Eigen::Index i = 0; i < nf; ++i) {
    if (problem.support(i)) continue;
    const Eigen::Index column = nu - nf + i;
    Hz.row(column).setZero();
    Hz.col(column).setZero();
    Hz(column, column) = 1.0;
    gz(column) = 0.0;
    Cz.col(column).setZero();
  }
  if (!problem.support.all()) {
    // Rows on those forces only (their bounds) now read 0 <= dz: infeasible if dz < 0, else
    // left out (DAQP scales each row by its norm: a zero row is no row for it).
    Eigen::Index kept = 0;
    for (Eigen::Index r = 0; r < Cz.rows(); ++r) {
      if (Cz.row(r).squaredNorm() == 0.0) {
        if (dz(r) < 0.0) return false;
        continue;
      }
      if (kept != r) {
        Cz.row(kept) = Cz.row(r);
        dz(kept) = dz(r);
      }
      ++kept;
    }
    Cz.conservativeResize(kept, Eigen::NoChange);
    dz.conservativeResize(kept);
  }
  if (!solve_qp_kept(Hz, gz, Cz, dz, u, &report)) return false;
  x = x0;  // x0 + Z u, Z's lower block being the identity
  x.head<k>().noalias() += Zt * u;
  x.tail(nu) += u;
  return true;
}
}  // namespace

void solve_weighted(const HierarchyProblem& problem, HierarchySolution& out) {
  // The QP's matrices, kept from tick to tick (one set per thread, as the solver's).
  thread_local Eigen::MatrixXd H, C, A;
  thread_local Eigen::VectorXd g, d, b, rows;
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
  C.resize(inequalities, nx);
  d.resize(inequalities);
  Eigen::Index row = 0;
  for (const Level& level : problem.levels) {
    C.middleRows(row, level.d.size()) = level.C;
    d.segment(row, level.d.size()) = level.d;
    row += level.d.size();
  }
  out.levels.assign(problem.levels.size(), LevelStatus::qp);
  out.qp_solves = 1;
  QpReport report;
  if (lightest >= kWellConditionedWeight)
    out.ok = solve_reduced(problem, kRegularization * lightest, C, d, out.x, report);
  // The QP as the Python kernel poses it: H, g over x and the Newton-Euler rows. Also where the
  // reduced QP found no u: with a lifted sole (herzog_table4) its six force rows are held at zero
  // by pairs of opposite rows and weigh ~1e-7 against the contacts' 1e4, and DAQP then declared
  // some feasible reduced QPs infeasible that it solves in this form (as the Python kernel does).
  if (!out.ok) {
    if (lightest >= kWellConditionedWeight) out.qp_solves = 2;  // the reduced QP, then this one
    H.setZero(nx, nx);
    H.diagonal().setConstant(kRegularization * lightest);
    g.setZero(nx);
    for (const Level& level : problem.levels) {
      // H is symmetric: the lower triangle's rank update only, mirrored below.
      H.selfadjointView<Eigen::Lower>().rankUpdate(level.A.transpose(), level.weight);
      g.noalias() -= level.weight * level.A.transpose() * level.b;
    }
    H.triangularView<Eigen::StrictlyUpper>() = H.transpose();
    if (problem.support.all()) {
      out.ok = solve_qp(H, g, C, d, problem.dynamics_A, problem.dynamics_b, out.x, &report);
    } else {  // and F_j = 0 for every force row out of support
      const Eigen::Index nf = problem.support.size(), free = nf - problem.support.count();
      const Eigen::Index dynamics = problem.dynamics_b.size();
      A.setZero(dynamics + free, nx);
      b.setZero(dynamics + free);
      A.topRows(dynamics) = problem.dynamics_A;
      b.head(dynamics) = problem.dynamics_b;
      for (Eigen::Index i = 0, row = dynamics; i < nf; ++i)
        if (!problem.support(i)) A(row++, nx - nf + i) = 1.0;
      out.ok = solve_qp(H, g, C, d, A, b, out.x, &report);
    }
  }
  if (!out.ok) {
    // Bounded whatever the problem: DAQP stops at its iteration limit or on a cycle.
    out.message = report.exitflag == 0
                      ? std::string("the base block of the mass matrix is singular")
                      : std::string("DAQP found no solution of the weighted QP: ") +
                            qp_exit_name(report.exitflag) + " (exit flag " +
                            std::to_string(report.exitflag) + ", " +
                            std::to_string(report.iterations) + " iterations)";
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
