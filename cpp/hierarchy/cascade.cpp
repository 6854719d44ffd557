// Strict priorities as a cascade of QPs with null-space reduction (Herzog 2016, §2.2);
// mirrors lab/controller/hierarchy/cascade.py, whose docstring derives each step.

#include <algorithm>
#include <utility>
#include <vector>

#include "hierarchy/linalg.hpp"
#include "hierarchy/problem.hpp"
#include "hierarchy/qp.hpp"

namespace lab {
namespace {

// eps of the cascade's proximal term: none (cascade.py REGULARIZATION). The level QP's Hessian is
// semi-definite and DAQP solves it by its own proximal loop in one call; a level that the solver
// wrongly calls infeasible is solved again with kRetryRegularization, by proximal solves from
// each optimum until the level's A Z u settles (cascade.py PROXIMAL_SOLVES, PROXIMAL_TOL).
constexpr double kRegularization = 0.0;
constexpr int kProximalSolves = 8;
constexpr double kProximalTol = 1e-10;
constexpr double kRetryRegularization = 1e-6;
// DAQP's stopping tolerance of its own proximal loop on a level QP (cascade.py LEVEL_ETA_PROX).
constexpr double kLevelEtaProx = 1e-9;
constexpr double kFeasibilityTol = 1e-9;  // a step that violates no row by more is taken as is
constexpr double kZeroRowTol = 1e-10;     // a kept inequality with no freedom left is dropped

/// What the cascade keeps from tick to tick: no allocation on the equality path once the
/// stack's shapes have been seen (one set per thread, as the QP solver's).
struct Buffers {
  BaseBlockLU lu;
  Eigen::MatrixXd Z_all, Z0, Z;  // the dynamics' null space: all columns, support ones; a copy
  Eigen::VectorXd x0, x, rows;   // the dynamics' solution; the equality pass's; row scratch
  std::vector<LeastSquaresStep> steps;  // one per level
};

Buffers& buffers() {
  thread_local Buffers b;
  return b;
}

/// Z and x of level 0: the Newton-Euler rows, with no force on a contact out of support.
bool dynamics_solution(const HierarchyProblem& problem, Buffers& b) {
  Eigen::MatrixXd& Z_all = b.Z_all;
  if (!solution_and_null_space_of_leading_block(problem.dynamics_A, problem.dynamics_b, Z_all, b.x0,
                                                b.lu))
    return false;
  const Eigen::Index nf = problem.support.size();
  const Eigen::Index nj = Z_all.cols() - nf;  // Z's columns: joint accelerations, then forces
  const Eigen::Index kept = nj + problem.support.count();
  if (kept == Z_all.cols()) {
    b.Z0 = Z_all;
    return true;
  }
  b.Z0.resize(Z_all.rows(), kept);
  b.Z0.leftCols(nj) = Z_all.leftCols(nj);
  Eigen::Index column = nj;
  for (Eigen::Index i = 0; i < nf; ++i)
    if (problem.support(i)) b.Z0.col(column++) = Z_all.col(nj + i);
  return true;
}

/// The cascade of the equality rows alone: one least squares and null space per level, into
/// b.x. The last level with equality rows takes its step without shrinking Z.
void equalities_only(const HierarchyProblem& problem, Buffers& b, LevelClock& clock) {
  clock.start();
  b.Z = b.Z0;
  b.x = b.x0;
  Eigen::Index first = 0, cols = b.Z.cols();
  std::size_t last = 0;
  for (std::size_t depth = 0; depth < problem.levels.size(); ++depth)
    if (problem.levels[depth].b.size()) last = depth;
  b.steps.resize(problem.levels.size());
  // Every contact in support: Z0 is [-A1^-1 A2; I] until a level's step rotates it.
  const bool all_support = b.Z0.cols() == b.Z_all.cols();
  for (std::size_t depth = 0; depth < problem.levels.size(); ++depth) {
    const Level& level = problem.levels[depth];
    if (level.b.size() && cols)
      least_squares_step(b.Z, first, cols, b.x, level.A, level.b, b.steps[depth], depth != last,
                         all_support && first == 0);
    clock.lap(depth);
  }
}

/// The first n entries of `buffer`, which grows to hold them and never shrinks: scratch whose
/// size changes level by level without a reallocation each time.
Eigen::VectorXd::SegmentReturnType scratch(Eigen::VectorXd& buffer, Eigen::Index n) {
  if (buffer.size() < n) buffer.resize(n);
  return buffer.head(n);
}

/// Whether C x <= d holds within kFeasibilityTol, with `rows` as scratch.
bool satisfies(const Eigen::MatrixXd& C, const Eigen::VectorXd& x, const Eigen::VectorXd& d,
               Eigen::VectorXd& rows) {
  if (d.size() == 0) return true;
  auto Cx = scratch(rows, C.rows());
  Cx.noalias() = C * x;
  return ((Cx - d).array() <= kFeasibilityTol).all();
}

/// Stack rows [top; bottom] (either may be empty).
Eigen::MatrixXd stacked(const Eigen::MatrixXd& top, const Eigen::MatrixXd& bottom) {
  Eigen::MatrixXd out(top.rows() + bottom.rows(), top.cols());
  out << top, bottom;
  return out;
}
Eigen::VectorXd stacked(const Eigen::VectorXd& top, const Eigen::VectorXd& bottom) {
  Eigen::VectorXd out(top.size() + bottom.size());
  out << top, bottom;
  return out;
}

/// Rows of G with freedom left (squared norm above kZeroRowTol^2), and their bounds.
void rows_with_freedom(const Eigen::MatrixXd& G, const Eigen::VectorXd& h, Eigen::MatrixXd& G_free,
                       Eigen::VectorXd& h_free) {
  std::vector<Eigen::Index> free;
  for (Eigen::Index i = 0; i < G.rows(); ++i)
    if (G.row(i).squaredNorm() > kZeroRowTol * kZeroRowTol) free.push_back(i);
  G_free.resize(static_cast<Eigen::Index>(free.size()), G.cols());
  h_free.resize(static_cast<Eigen::Index>(free.size()));
  for (std::size_t i = 0; i < free.size(); ++i) {
    G_free.row(static_cast<Eigen::Index>(i)) = G.row(free[i]);
    h_free(static_cast<Eigen::Index>(i)) = h(free[i]);
  }
}

/// A minimiser of ||Az u - r||^2 + ||v||^2 over G [u; v] <= h (eqs. 10-11): one solve at eps = 0,
/// else proximal steps eps ||u - u0||^2 from the least-squares step u (exact where a fixed
/// eps ||u||^2 would leak).
bool level_optimum(Eigen::VectorXd& u, const Eigen::MatrixXd& Az, const Eigen::VectorXd& r,
                   const Eigen::MatrixXd& G, const Eigen::VectorXd& h, double epsilon,
                   int& qp_solves) {
  const Eigen::Index nz = Az.cols(), m = G.cols() - nz;
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(nz + m, nz + m);
  P.topLeftCorner(nz, nz).noalias() = Az.transpose() * Az;
  P.topLeftCorner(nz, nz).diagonal().array() += epsilon;
  P.bottomRightCorner(m, m).setIdentity();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(nz + m), solution;
  const Eigen::VectorXd Atr = Az.transpose() * r;
  Eigen::VectorXd w = Az * u;
  for (int i = 0; i < kProximalSolves; ++i) {
    q.head(nz) = -Atr - epsilon * u;
    ++qp_solves;
    if (!solve_qp(P, q, G, h, solution, nullptr, kLevelEtaProx)) return false;
    u = solution.head(nz);
    if (epsilon == 0.0) break;  // no term to vanish: DAQP's own proximal loop reached the optimum
    const Eigen::VectorXd previous = std::exchange(w, Az * u);
    if ((w - previous).norm() <= kProximalTol * (1.0 + w.norm())) break;
  }
  return true;
}

/// Among the optimal steps u + N w of a level (same Az u, slacks no larger than u's, carried
/// bounds kept), the one with the smallest ||x + Z (u + N w)|| (Herzog eq. 5).
Eigen::VectorXd smallest_in_optimal_set(const Eigen::VectorXd& u, const Eigen::MatrixXd& N,
                                        const Eigen::MatrixXd& Cz, const Eigen::VectorXd& s,
                                        const Eigen::MatrixXd& K, const Eigen::VectorXd& k,
                                        const Eigen::MatrixXd& Z, const Eigen::VectorXd& x,
                                        int& qp_solves) {
  if (N.cols() == 0) return u;
  const Eigen::MatrixXd ZN = Z * N;
  // Bounds of w: each row keeps the room it has at u (>= 0: w = 0 is feasible).
  const Eigen::MatrixXd G = stacked(Eigen::MatrixXd(Cz * N), Eigen::MatrixXd(K * N));
  const Eigen::VectorXd h =
      stacked(Eigen::VectorXd(s - Cz * u), Eigen::VectorXd(k - K * u)).cwiseMax(0.0);
  Eigen::MatrixXd G_free;
  Eigen::VectorXd h_free, w;
  rows_with_freedom(G, h, G_free, h_free);
  ++qp_solves;
  const Eigen::MatrixXd P = ZN.transpose() * ZN;
  const Eigen::VectorXd q = ZN.transpose() * (x + Z * u);
  // On failure u is still optimal for the level; only the smallest x among its optima is lost.
  if (!solve_qp(P, q, G_free, h_free, w)) return u;
  // The solver's tolerance may overstep a row the level's optimum already sits on: step back
  // along w until every row is within its room again (w = 0 always is).
  const Eigen::VectorXd rate = G_free * w;
  double step = 1.0;
  for (Eigen::Index i = 0; i < rate.size(); ++i)
    if (rate(i) > h_free(i)) step = std::min(step, h_free(i) / rate(i));
  return u + step * (N * w);
}

/// The step u in the null space for one level (eqs. 9-11) where its least-squares step violates
/// an inequality, given that step and the null space N of its equality rows; the slacks are
/// implicit in the cost. Sets `status`.
Eigen::VectorXd solve_level(const Eigen::VectorXd& u_ls, const Eigen::MatrixXd& Az,
                            const Eigen::VectorXd& r, const Eigen::MatrixXd& N,
                            const Eigen::MatrixXd& Cz, const Eigen::VectorXd& s,
                            const Eigen::MatrixXd& K, const Eigen::VectorXd& k,
                            const Eigen::MatrixXd& Z, const Eigen::VectorXd& x, LevelStatus& status,
                            int& qp_solves) {
  const Eigen::Index nz = Az.cols(), m = s.size();
  // Over (u, v): C u - v <= s (the level's rows with their slacks), K u <= k (carried rows).
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(m + K.rows(), nz + m);
  G.topLeftCorner(m, nz) = Cz;
  G.topRightCorner(m, m) = -Eigen::MatrixXd::Identity(m, m);
  G.bottomLeftCorner(K.rows(), nz) = K;
  const Eigen::VectorXd h = stacked(s, k);
  for (const double epsilon : {kRegularization, kRetryRegularization}) {
    Eigen::VectorXd u = u_ls;
    if (level_optimum(u, Az, r, G, h, epsilon, qp_solves)) {
      status = LevelStatus::qp;
      return smallest_in_optimal_set(u, N, Cz, s, K, k, Z, x, qp_solves);
    }
  }
  // u = 0 is feasible by construction, so this is the solver failing, not the level: the
  // level keeps the solution of the levels above.
  status = LevelStatus::kept_above;
  return Eigen::VectorXd::Zero(nz);
}

/// The cascade of eqs. 9-11, one QP per level where an inequality binds.
void with_inequalities(const HierarchyProblem& problem, Eigen::MatrixXd Z, Eigen::VectorXd x,
                       HierarchySolution& out, LevelClock& clock) {
  clock.start();
  // Inequalities of the levels above, kept as their rows over x (C_above) with the room k each
  // has left within the slack its level reached (eq. 9): in null-space coordinates they are
  // C_above Z u <= k, a product formed only for a level that poses a QP (the others need
  // C_above (Z u) alone). k >= 0, so u = 0 is feasible for every level.
  Eigen::MatrixXd C_above(0, x.size());
  Eigen::VectorXd k(0), step, rows;
  const std::size_t last = problem.levels.size() - 1;
  for (std::size_t depth = 0; depth < problem.levels.size(); ++depth) {
    const Level& level = problem.levels[depth];
    if (Z.cols() == 0) {
      out.levels[depth] = LevelStatus::no_freedom;
      clock.lap(depth);
      continue;
    }
    Eigen::MatrixXd Az;
    sparse_rows_product(level.A, Z, Az);
    const Eigen::VectorXd r = level.b - level.A * x, s = level.d - level.C * x;
    Eigen::VectorXd u;
    Eigen::MatrixXd N;
    least_squares_and_null_space(Az, r, u, N);
    // When the least-squares step violates no inequality, (u, v = 0) is optimal. Without
    // equalities that step is u = 0, which the carried bounds always allow (k >= 0).
    step.noalias() = Z * u;
    if (satisfies(level.C, step, s, rows) && satisfies(C_above, step, k, rows)) {
      out.levels[depth] = LevelStatus::exact;
    } else {
      Eigen::MatrixXd Cz, K, K_free;  // K: carried rows with freedom left in Z
      Eigen::VectorXd k_free;
      sparse_rows_product(level.C, Z, Cz);
      sparse_rows_product(C_above, Z, K);
      rows_with_freedom(K, k, K_free, k_free);
      u = solve_level(u, Az, r, N, Cz, s, K_free, k_free, Z, x, out.levels[depth], out.qp_solves);
      step.noalias() = Z * u;
    }
    x += step;
    if (depth == last) {
      clock.lap(depth);
      break;
    }
    if (s.size()) {
      C_above = stacked(C_above, level.C);
      k = stacked(k, s);
    }
    rows.noalias() = C_above * step;
    k = (k - rows).cwiseMax(0.0);
    if (r.size()) Z = (Z * N).eval();  // lock the directions this level's equalities used (eq. 8)
    clock.lap(depth);
  }
  out.x = std::move(x);
}

}  // namespace

void solve_cascade(const HierarchyProblem& problem, HierarchySolution& out) {
  Buffers& b = buffers();
  out.ok = false;
  out.message.clear();
  out.qp_solves = 0;
  out.levels.assign(problem.levels.size(), LevelStatus::exact);
  out.residuals.clear();
  LevelClock clock(out.level_seconds, problem.levels.size());
  if (!dynamics_solution(problem, b)) {
    out.message = "the base block of the mass matrix is singular";
    return;
  }
  equalities_only(problem, b, clock);
  bool feasible = true;
  for (const Level& level : problem.levels)
    feasible = feasible && satisfies(level.C, b.x, level.d, b.rows);
  if (feasible)
    out.x = b.x;
  else
    with_inequalities(problem, b.Z0, b.x0, out, clock);
  out.ok = out.x.allFinite();
  if (!out.ok) out.message = "non-finite solution";
  for (const LevelStatus status : out.levels)
    if (status == LevelStatus::kept_above)
      out.message = "a level QP failed; it keeps the solution of the levels above";
  for (const Level& level : problem.levels) {
    if (!level.b.size()) {
      out.residuals.push_back(0.0);
      continue;
    }
    auto residual = scratch(b.rows, level.b.size());
    residual = level.b;
    residual.noalias() -= level.A * out.x;
    out.residuals.push_back(residual.norm());
  }
}

HierarchySolution solve_cascade(const HierarchyProblem& problem) {
  HierarchySolution out;
  solve_cascade(problem, out);
  return out;
}

}  // namespace lab
