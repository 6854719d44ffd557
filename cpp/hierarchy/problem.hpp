// The input every hierarchy method takes, and the solution it returns (mirrors
// lab/controller/hierarchy/problem.py).
#pragma once

#include <Eigen/Dense>
#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace lab {

/// One priority level: equality rows A x = b (task weights already folded in) and
/// inequality rows C x <= d. `weight` scales the level in the weighted method only.
struct Level {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  Eigen::MatrixXd C;
  Eigen::VectorXd d;
  double weight = 1.0;
  // (name, number of rows) of each constraint in C, in order: for wbosc, which reports rather
  // than enforces inequalities.
  std::vector<std::pair<std::string, Eigen::Index>> constraint_rows;
};

/// The active rows of each level's C, as one active-set search of `nullspace` left them.
using ActiveSet = std::vector<Eigen::Array<bool, Eigen::Dynamic, 1>>;

/// The model terms behind the Newton–Euler rows, M q̈ + h − J_cᵀ F = Sᵀ τ (problem.py
/// DynamicsTerms), for the methods that change variables (nullspace's formulations, wbosc):
/// views of the model's own arrays (null: not filled); for wbosc also the drift J̇_c v and the
/// weight w ∈ [0, 1] of each row of F whose contact is being loaded or unloaded (NaN: not
/// changing; empty: none).
struct DynamicsTerms {
  const Eigen::MatrixXd* M = nullptr;
  const Eigen::VectorXd* h = nullptr;
  const Eigen::MatrixXd* Jc = nullptr;
  const Eigen::VectorXd* drift = nullptr;
  Eigen::VectorXd transition;
};

/// Find x = [qdd, F] with dynamics_A x = dynamics_b exactly (the Newton-Euler rows,
/// Herzog eq. 13), then each level in turn. `support` flags the rows of F that belong to
/// contacts in support (the others carry no force).
struct HierarchyProblem {
  Eigen::MatrixXd dynamics_A;
  Eigen::VectorXd dynamics_b;
  std::vector<Level> levels;
  Eigen::Array<bool, Eigen::Dynamic, 1> support;
  // `nullspace` only (problem.py): the model terms, the optimization vector of Hutter 2014 §4
  // (formulations.hpp), and where the last tick's searches stopped (`active_start`, one
  // ActiveSet per search) and its x (`x_start`), to start from; null: a cold start.
  DynamicsTerms terms;
  std::string formulation = "qdd_force";
  const std::vector<ActiveSet>* active_start = nullptr;
  const Eigen::VectorXd* x_start = nullptr;
};

/// How one level was solved.
enum class LevelStatus {
  exact,       // least squares of its equalities; no inequality binds
  qp,          // a QP with slacks (Herzog eqs. 9-11)
  kept_above,  // the solver failed; the level keeps the solution of the levels above
  no_freedom,  // nothing left in the null space of the levels above
  projected,   // null-space projection with active inequalities (Hutter §3)
};

/// The name telemetry and the tests use for a level status.
inline const char* level_status_name(LevelStatus status) {
  switch (status) {
    case LevelStatus::exact:
      return "exact";
    case LevelStatus::qp:
      return "qp";
    case LevelStatus::kept_above:
      return "kept_above";
    case LevelStatus::no_freedom:
      return "no_freedom";
    case LevelStatus::projected:
      return "projected";
  }
  return "unknown";
}

/// The result of a hierarchy method: x and what happened on the way (TSID's HQPOutput).
struct HierarchySolution {
  Eigen::VectorXd x;
  bool ok = false;                    // false: x is not a solution (see message)
  std::string message;                // why not, or which levels fell back
  std::vector<LevelStatus> levels;    // one per problem level
  std::vector<double> residuals;      // ||A x - b|| of each level at the returned x
  std::vector<double> level_seconds;  // time spent on each level, over all passes
  int qp_solves = 0;
  // wbosc: each constraint of the stack violated at x, one line ("level 0 friction: exceeded
  // by 2.5"); the closed form reports inequalities rather than enforcing them.
  std::vector<std::string> violations;
  // `nullspace` only: whether an active-set search stopped at its cap (message says where),
  // the hierarchy solves of all its searches, and the active rows where each search stopped.
  bool capped = false;
  int projections = 0;
  std::vector<ActiveSet> active_sets;
};

/// Seconds spent on each level, accumulated over the passes of a method (solution.py LevelClock).
class LevelClock {
 public:
  explicit LevelClock(std::vector<double>& seconds, std::size_t levels) : seconds_(seconds) {
    seconds_.assign(levels, 0.0);
    start();
  }
  /// Start timing the first level of a pass from now.
  void start() { start_ = Clock::now(); }
  /// Charge the time since the last lap to `level`.
  void lap(std::size_t level) {
    const auto now = Clock::now();
    seconds_[level] += std::chrono::duration<double>(now - start_).count();
    start_ = now;
  }

 private:
  using Clock = std::chrono::steady_clock;
  std::vector<double>& seconds_;
  Clock::time_point start_;
};

/// Strict priorities: a cascade of QPs with null-space reduction (Herzog 2016 §2.2).
HierarchySolution solve_cascade(const HierarchyProblem& problem);
/// The same into `out`, whose storage is reused (the kernel's tick allocates nothing).
void solve_cascade(const HierarchyProblem& problem, HierarchySolution& out);

/// All levels in one weighted QP (Raiola 2020, stack S1).
HierarchySolution solve_weighted(const HierarchyProblem& problem);
/// The same into `out`, whose storage is reused.
void solve_weighted(const HierarchyProblem& problem, HierarchySolution& out);

/// Whole-Body Operational Space Control, closed form (Kim 2016 App. A); reads problem.terms.
HierarchySolution solve_wbosc(const HierarchyProblem& problem);
/// The same into `out`, whose storage is reused.
void solve_wbosc(const HierarchyProblem& problem, HierarchySolution& out);
/// Hierarchy solves one `nullspace` call makes at most (nullspace.py MAX_PROJECTIONS).
constexpr int kMaxProjections = 128;
/// Iterative null-space projection with inequalities activated when violated (Hutter 2014 §3).
HierarchySolution solve_nullspace(const HierarchyProblem& problem);
/// The same into `out`, whose storage is reused.
void solve_nullspace(const HierarchyProblem& problem, HierarchySolution& out);

}  // namespace lab
