// Hierarchical least squares by iterative null-space projection (Hutter 2014, §3); mirrors
// lab/controller/hierarchy/nullspace.py, whose docstring derives each rule. Each priority solves
// its rows in the null space of all rows above (eqs. 8-11),
//   z <- z + Z (A Z)⁺ (b − A z),   Z <- Z ∩ null(A Z),
// with Z an orthonormal basis, the pseudo-inverse and the next null space from one pivoted QR of
// (A Z)ᵀ with linalg's rank rule (RowSpaceQR, the cascade's: one rule in both kernels).
// Inequalities C z <= d are off until violated (§3.2), then a primal active set: the most
// violated row of the highest violated level is activated (one per solve), a row is released
// when the hierarchy solved without it keeps it inside its bound (a trial the main solve's own
// factorizations predict clearly to keep it is not solved: predicted_violation), and z steps
// towards each new optimum only as far as the first row it would cross (ties: the smallest
// index, Bland's rule).
// At most kMaxProjections hierarchy solves per call; at the cap the best point found is kept
// and the solution says `capped`.
// Over 400 lines: one method (nullspace.py, ~400 lines in Python), longer in C++ by its explicit
// buffers and loops.

#include "hierarchy/nullspace.hpp"

#include <algorithm>
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "hierarchy/formulations.hpp"
#include "hierarchy/linalg.hpp"
#include "hierarchy/problem.hpp"

namespace lab {
namespace {

constexpr double kActivationTol = 1e-9;  // ACTIVATION_TOL: violated by more is activated
constexpr double kRatioTie = 1e-12;      // RATIO_TIE: step lengths this close block together
constexpr Eigen::Index kNone = -1;
// RELEASE_BAND, RELEASE_MARGIN: a release trial decided from the main solve (predicted_violation)
constexpr double kReleaseBandLow = 1e-14, kReleaseBandHigh = 1e-11;
constexpr double kReleaseMargin = 1e-6;

using Flags = Eigen::Array<bool, Eigen::Dynamic, 1>;

/// (z, Z) on entering one level of a hierarchy solve (nullspace.py's `entry`). Z is the `cols`
/// columns of `Z_buffer` (n x n, kept from tick to tick) from `first` on: each level's step
/// takes the leading columns of Z Q, so the null space left is the window's tail.
struct Entry {
  Eigen::VectorXd z;
  Eigen::MatrixXd Z_buffer;
  Eigen::Index first = 0, cols = 0;
  bool identity = false;  // Z is the identity (no level has stepped yet)

  void swap(Entry& other) {
    z.swap(other.z);
    Z_buffer.swap(other.Z_buffer);
    std::swap(first, other.first);
    std::swap(cols, other.cols);
    std::swap(identity, other.identity);
  }
};

/// The storage of one equality step (a level's A, or its active rows of C): sized once. `step`
/// holds the pivoted QR of (A Z)ᵀ, A Z, the residual r and y; the last level's also the
/// unpivoted QR of A Z (linalg's full_rank_step).
struct StepWork {
  enum class Used { none, pivoted, full_rank };  // which factorization the step left, if any
  LeastSquaresStep step;
  Eigen::MatrixXd Q;
  Eigen::MatrixXd tail, kept;  // Q [y | 0; 0 | I] and Z Q's free columns (least_squares_step)
  Used used = Used::none;
  // predicted_violation's, per step so that their sizes stay put: M δ, its y and residual g,
  // the correction in Z's columns and lifted to the level's entry Z, Q^T of M δ and of r
  Eigen::VectorXd moved, y, g, correction, lifted, rotated_moved, rotated_r;
};

/// Whether Z Q's step and free columns cost fewer multiplications as Z (Q [y | 0; 0 | I]) than
/// as Q's `reflectors` applied to Z (n x cols) itself: reflector k touches cols − k columns of
/// each row, two multiplications per entry; the tail applies them to 1 + left columns of cols
/// rows, then multiplies Z by it.
bool tail_is_cheaper(Eigen::Index n, Eigen::Index cols, Eigen::Index reflectors,
                     Eigen::Index left) {
  const Eigen::Index h = reflectors, touched = h * cols - h * (h - 1) / 2;  // Σ_k<h (cols − k)
  return (1 + left) * (2 * touched + n * cols) < 2 * n * touched;
}

/// One active-set search over z (nullspace.py active_set_least_squares), its buffers kept from
/// tick to tick: no allocation while the shapes stay those of the last tick.
class ActiveSetSearch {
 public:
  /// Search over `levels` (rows over z ∈ Rⁿ) from the active rows `start` (ignored unless they
  /// match the levels' rows) and, where those rows' solution violates a row, from `point`.
  void run(const std::vector<const Level*>& levels, Eigen::Index n, const ActiveSet* start,
           const Eigen::VectorXd* point, int cap = kMaxProjections);

  Eigen::VectorXd z;  // where the search stopped
  ActiveSet active;   // the active rows of each level's C there
  int projections = 0;
  bool capped = false, feasible = true;

 private:
  bool take();  // _Budget.take: whether one more solve fits
  bool violates(const Eigen::VectorXd& at);
  void project(Eigen::Index first);
  void project_from(const Entry& from, Eigen::Index first, std::vector<Entry>& out, bool trial);
  void least_squares_step(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, Entry& e,
                          StepWork& work, const SparseRows* sparsity = nullptr, bool last = false);
  Eigen::Index activate_violated();
  bool release_one();
  bool predicted_violation(std::size_t k, Eigen::Index j, double& violation);
  const Eigen::VectorXd& in_entry_columns(std::size_t s, StepWork& work);
  StepWork& work_of(std::size_t s, bool trial) { return work_[s][trial ? 1 - main_[s] : main_[s]]; }
  void walked();
  Eigen::Index step();

  const std::vector<const Level*>* levels_ = nullptr;
  Eigen::Index n_ = 0;
  int cap_ = kMaxProjections;
  bool ran_out_ = false;
  std::vector<Entry> entry_, trial_;  // (z, Z) on entering each level; [L]: the solution
  Eigen::VectorXd target_, dz_, rows_, rate_;
  Eigen::MatrixXd Ca_;  // the active rows of C
  Eigen::VectorXd da_;
  // per level: [2k] its active rows of C, [2k + 1] its A; main_[s] says which of the two is the
  // main solve's (entry_'s), the other is the trials' (trial_'s); they swap with the entries
  std::vector<std::array<StepWork, 2>> work_;
  std::vector<int> main_;
  Eigen::VectorXd delta_;             // predicted_violation's direction
  std::vector<SparseRows> sparsity_;  // per level: its A's sparse rows, found once per search
};

bool ActiveSetSearch::take() {
  ran_out_ = ran_out_ || projections >= cap_;
  return !ran_out_;
}

void ActiveSetSearch::run(const std::vector<const Level*>& levels, Eigen::Index n,
                          const ActiveSet* start, const Eigen::VectorXd* point, int cap) {
  levels_ = &levels;
  n_ = n;
  cap_ = cap;
  projections = 0;
  ran_out_ = false;
  const std::size_t L = levels.size();
  bool matches = start && start->size() == L;
  for (std::size_t k = 0; matches && k < L; ++k)
    matches = (*start)[k].size() == levels[k]->d.size();
  active.resize(L);
  for (std::size_t k = 0; k < L; ++k) {
    if (matches)
      active[k] = (*start)[k];
    else
      active[k].setConstant(levels[k]->d.size(), false);
  }
  entry_.resize(L + 1);
  trial_.resize(L + 1);
  work_.resize(2 * L);
  main_.assign(2 * L, 0);
  sparsity_.resize(L);
  for (std::size_t k = 0; k < L; ++k) sparsity_[k].compute(levels[k]->A);
  entry_[0].z.setZero(n);
  entry_[0].Z_buffer.setIdentity(n, n);
  entry_[0].first = 0;
  entry_[0].cols = n;
  entry_[0].identity = true;
  project(0);
  z = entry_[L].z;
  if (point && point->size() == n && violates(z)) {
    // A primal start (nullspace.py): pin the rows the last tick's point violates, then walk
    // from it to the solution, activating the rows crossed on the way.
    for (std::size_t k = 0; k < L; ++k) {
      const Level& level = *levels[k];
      rows_.noalias() = level.C * *point;
      active[k] = active[k] || (rows_ - level.d).array() > kActivationTol;
    }
    project(0);
    target_ = entry_[L].z;
    z = *point;
    walked();
    if (ran_out_) {
      capped = feasible = true;
      return;
    }
  }
  for (Eigen::Index k; (k = activate_violated()) != kNone;) {  // §3.2
    if (!take()) {
      capped = true;
      feasible = false;
      return;
    }
    project(k);
    z = entry_[L].z;
  }
  // z satisfies every inequality from here on: each step stops at the first row it would cross
  while (release_one()) {
    walked();
    if (ran_out_) break;
  }
  capped = ran_out_;
  feasible = true;
}

bool ActiveSetSearch::violates(const Eigen::VectorXd& at) {
  for (std::size_t k = 0; k < levels_->size(); ++k) {
    const Level& level = *(*levels_)[k];
    if (!level.d.size()) continue;
    rows_.noalias() = level.C * at;
    for (Eigen::Index i = 0; i < level.d.size(); ++i)
      if (!active[k](i) && rows_(i) - level.d(i) > kActivationTol) return true;
  }
  return false;
}

void ActiveSetSearch::walked() {
  // From z towards target_, re-solved each time a row blocks the way and is activated.
  while (true) {
    const Eigen::Index k = step();
    if (k == kNone || !take()) return;
    project(k);
    target_ = entry_[levels_->size()].z;
  }
}

Eigen::Index ActiveSetSearch::activate_violated() {
  // The most violated row of the highest-priority level that has any; rows violated as much
  // within kActivationTol (relative) tie, broken by the smallest index (Bland's rule).
  for (std::size_t k = 0; k < levels_->size(); ++k) {
    const Level& level = *(*levels_)[k];
    if (!level.d.size()) continue;
    rows_.noalias() = level.C * z;
    double worst = 0.0;
    for (Eigen::Index i = 0; i < level.d.size(); ++i)
      if (!active[k](i)) worst = std::max(worst, rows_(i) - level.d(i));
    if (!(worst > kActivationTol)) continue;
    for (Eigen::Index i = 0; i < level.d.size(); ++i)
      if (!active[k](i) && rows_(i) - level.d(i) >= worst - kActivationTol * worst) {
        active[k](i) = true;
        return static_cast<Eigen::Index>(k);
      }
  }
  return kNone;
}

bool ActiveSetSearch::release_one() {
  // Release the first active row the hierarchy solved without it keeps inside its bound; its
  // solution becomes target_. Each trial reuses the levels above the row's.
  const std::size_t L = levels_->size();
  for (std::size_t k = 0; k < L; ++k) {
    const Level& level = *(*levels_)[k];
    for (Eigen::Index j = 0; j < active[k].size(); ++j) {
      if (!active[k](j)) continue;
      double predicted = 0.0;
      if (predicted_violation(k, j, predicted) &&
          predicted - kActivationTol > kReleaseMargin * std::max(1.0, std::abs(level.d(j))))
        continue;  // kept, as the trial would have kept it: no hierarchy solve
      if (!take()) return false;
      active[k](j) = false;
      project_from(entry_[k], static_cast<Eigen::Index>(k), trial_, true);
      const Eigen::VectorXd& released = trial_[L].z;
      if (level.C.row(j).dot(released) - level.d(j) <= kActivationTol) {
        for (std::size_t i = k + 1; i <= L; ++i) entry_[i].swap(trial_[i]);
        for (std::size_t s = 2 * k; s < 2 * L; ++s) main_[s] = 1 - main_[s];
        target_ = entry_[L].z;
        return true;
      }
      active[k](j) = true;
    }
  }
  return false;
}

bool ActiveSetSearch::predicted_violation(std::size_t k, Eigen::Index j, double& violation) {
  // nullspace.py _predicted_violation (its docstring derives it), from the main solve's own
  // factorizations (entry_ and the main StepWork of each step): per step below, products with
  // one vector and its reflectors applied to one vector, no factorization. False where the
  // prediction is not clear-cut (then the trial runs).
  const std::vector<const Level*>& levels = *levels_;
  const std::size_t L = levels.size();
  StepWork& pinned = work_of(2 * k, false);
  if (entry_[k].cols == 0 || pinned.used != StepWork::Used::pivoted ||
      !pinned.step.qr.rank_by_margin())
    return false;
  // δ = Z (C_on Z)⁺ e_j: the direction releasing row j frees, C_j δ = 1
  pinned.moved.setZero(active[k].count());
  pinned.moved(active[k].head(j).count()) = 1.0;
  pinned.step.qr.solve(pinned.moved, pinned.y);
  delta_.setZero(n_);
  const Eigen::VectorXd& freed = in_entry_columns(2 * k, pinned);
  if (entry_[k].identity)
    delta_ += freed;
  else
    delta_.noalias() += entry_[k].Z_buffer.middleCols(entry_[k].first, entry_[k].cols) * freed;
  for (std::size_t s = 2 * k + 1; s < 2 * L; ++s) {  // [2k'] C's active rows, [2k' + 1] A
    const std::size_t of = s / 2;
    const Level& level = *levels[of];
    const bool pinned_rows = s % 2 == 0;
    const Flags& on = active[of];
    const Eigen::Index m = pinned_rows ? on.count() : level.b.size();
    if (m == 0) continue;
    StepWork& work = work_of(s, false);
    work.moved.resize(m);  // M δ
    if (pinned_rows) {
      for (Eigen::Index i = 0, row = 0; i < on.size(); ++i)
        if (on(i)) work.moved(row++) = level.C.row(i).dot(delta_);
    } else {
      work.moved.noalias() = level.A * delta_;
    }
    const double moved_size = std::max(1.0, work.moved.norm());
    double ratio = 0.0;
    if (work.used == StepWork::Used::none) {
      // no freedom left from here (the step did not run): M Z has no columns, g = M δ, and z is
      // the solution's, r = b − M z
      ratio = work.moved.norm() / moved_size;
      if (ratio > kReleaseBandHigh) {
        const Eigen::VectorXd& z_final = entry_[L].z;
        double along = 0.0;
        for (Eigen::Index i = 0, row = 0; i < (pinned_rows ? on.size() : m); ++i) {
          if (pinned_rows && !on(i)) continue;
          const double r = pinned_rows ? level.d(i) - level.C.row(i).dot(z_final)
                                       : level.b(i) - level.A.row(i).dot(z_final);
          along += work.moved(row++) * r;
        }
        violation = along / work.moved.squaredNorm();
        return true;
      }
      if (ratio >= kReleaseBandLow) return false;
      continue;
    }
    if (work.used == StepWork::Used::full_rank) {
      // the last level's unpivoted A Z = Q R: g = Q₂ Q₂ᵀ M δ, gᵀr = (Q₂ᵀ M δ)ᵀ (Q₂ᵀ r)
      const Eigen::Index cols = work.step.full_rank_qr.cols();
      work.rotated_moved = work.moved;
      work.rotated_r = work.step.r;
      apply_qt_to_vector(work.step.full_rank_qr, work.rotated_moved);
      apply_qt_to_vector(work.step.full_rank_qr, work.rotated_r);
      const auto g = work.rotated_moved.tail(m - cols);
      ratio = g.norm() / (std::max(1.0, work.step.AZ.norm()) * moved_size);
      if (!(ratio > kReleaseBandHigh)) return false;  // the last level: none below to decide
      violation = g.dot(work.rotated_r.tail(m - cols)) / g.squaredNorm();
      return true;
    }
    work.step.qr.solve_with_residual(work.moved, work.y, work.g);
    ratio = work.g.norm() / (std::max(1.0, work.step.qr.frobenius()) * moved_size);
    if (ratio > kReleaseBandHigh) {
      violation = work.g.dot(work.step.r) / work.g.squaredNorm();
      return true;
    }
    if (ratio >= kReleaseBandLow) return false;
    if (work.y.size() == 0) continue;
    // δ <- δ − Z (M Z)⁺ M δ: this step's correction, carried on
    const Entry& e = entry_[of];
    const Eigen::VectorXd& correction = in_entry_columns(s, work);
    if (e.identity)
      delta_ -= correction;
    else
      delta_.noalias() -= e.Z_buffer.middleCols(e.first, e.cols) * correction;
  }
  return false;
}

const Eigen::VectorXd& ActiveSetSearch::in_entry_columns(std::size_t s, StepWork& work) {
  // Z_s Q [y; 0] of step s as coefficients of its level's entry Z: the C rows' step has Z_s = Z,
  // the A rows' Z_s = Z Q_C [0; I] after a C step that stepped (its window's tail).
  const Entry& e = entry_[s / 2];
  const RowSpaceQR* before = nullptr;
  if (s % 2) {
    const StepWork& pinned = work_of(s - 1, false);
    if (pinned.used == StepWork::Used::pivoted && pinned.step.qr.rank() > 0)
      before = &pinned.step.qr;
  }
  const Eigen::Index cols = e.cols - (before ? before->rank() : 0);
  work.correction.setZero(cols);
  work.correction.head(work.y.size()) = work.y;
  work.step.qr.apply_q_to_vector(work.correction);
  work.lifted.setZero(e.cols);
  work.lifted.tail(cols) = work.correction;
  if (before) before->apply_q_to_vector(work.lifted);
  return work.lifted;
}

Eigen::Index ActiveSetSearch::step() {
  // Move z towards target_ as far as every inactive row z satisfies stays satisfied; activate
  // the row that blocks the move, if one does, and give its level.
  dz_ = target_ - z;
  double alpha = 1.0;
  Eigen::Index level_of = kNone, row_of = kNone;
  for (std::size_t k = 0; k < levels_->size(); ++k) {
    const Level& level = *(*levels_)[k];
    if (!level.d.size()) continue;
    rows_.noalias() = level.C * z;  // slack = d − C z
    rate_.noalias() = level.C * dz_;
    // Blocking only where the step would violate the row by more than the release tolerance;
    // among the closing rows the smallest ratio, ties by the smallest index (Bland's rule).
    double smallest = 0.0;
    Eigen::Index first = kNone;
    bool any = false;
    for (Eigen::Index i = 0; i < level.d.size(); ++i) {
      const double slack = level.d(i) - rows_(i);
      if (active[k](i) || slack < -kActivationTol || !(rate_(i) * alpha - slack > kActivationTol))
        continue;
      const double ratio = std::max(slack / rate_(i), 0.0);
      if (!any || ratio < smallest) smallest = ratio;
      any = true;
    }
    if (!any) continue;
    for (Eigen::Index i = 0; i < level.d.size() && first == kNone; ++i) {
      const double slack = level.d(i) - rows_(i);
      if (active[k](i) || slack < -kActivationTol || !(rate_(i) * alpha - slack > kActivationTol))
        continue;
      if (std::max(slack / rate_(i), 0.0) <= smallest + kRatioTie) first = i;
    }
    alpha = smallest;
    level_of = static_cast<Eigen::Index>(k);
    row_of = first;
  }
  if (level_of == kNone) {
    z = target_;
    return kNone;
  }
  active[level_of](row_of) = true;
  z += alpha * dz_;
  return level_of;
}

void ActiveSetSearch::project(Eigen::Index first) {
  project_from(entry_[first], first, entry_, false);
}

void ActiveSetSearch::project_from(const Entry& from, Eigen::Index first, std::vector<Entry>& out,
                                   bool trial) {
  // Solve levels `first`, ... from (z, Z) on entering `first`, writing each next level's entry
  // into `out`: one solve of the budget (nullspace.py _project).
  ++projections;
  const std::vector<const Level*>& levels = *levels_;
  for (std::size_t k = static_cast<std::size_t>(first); k < levels.size(); ++k) {
    const Level& level = *levels[k];
    Entry& next = out[k + 1];
    const Entry& here = k == static_cast<std::size_t>(first) ? from : out[k];
    next.z = here.z;
    next.Z_buffer.resize(n_, n_);  // no allocation once sized
    next.first = here.first;
    next.cols = here.cols;
    next.identity = here.identity;
    next.Z_buffer.middleCols(next.first, next.cols) =
        here.Z_buffer.middleCols(here.first, here.cols);
    const Flags& on = active[k];
    const Eigen::Index count = on.count();
    StepWork& pinned = work_of(2 * k, trial);
    pinned.used = StepWork::Used::none;
    if (count) {
      Ca_.resize(count, n_);
      da_.resize(count);
      for (Eigen::Index i = 0, row = 0; i < on.size(); ++i)
        if (on(i)) {
          Ca_.row(row) = level.C.row(i);
          da_(row++) = level.d(i);
        }
      least_squares_step(Ca_, da_, next, pinned);
    }
    least_squares_step(level.A, level.b, next, work_of(2 * k + 1, trial), &sparsity_[k],
                       k + 1 == levels.size());
  }
}

void ActiveSetSearch::least_squares_step(const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                                         Entry& e, StepWork& work, const SparseRows* sparsity,
                                         bool last) {
  // z <- z + Z (A Z)⁺ (b − A z), Z <- Z ∩ null(A Z) (eqs. 8-11), from the pivoted QR of
  // (A Z)ᵀ = Q [R1; 0] Pᵀ with linalg's rank rule: (A Z)⁺ r = Q1 (R1ᵀ)⁺ Pᵀ r, the next Z is Z Q2.
  // The last level's step (`last`) moves z only: no level below reads its null space (the
  // search restarts from the entries of the levels above it), so Z stays, and where its A Z has
  // full column rank by a margin the unpivoted QR of A Z gives the same unique step (the
  // cascade's last level, linalg's full_rank_step).
  work.used = StepWork::Used::none;
  if (b.size() == 0 || e.cols == 0) return;
  LeastSquaresStep& step = work.step;
  auto Z = e.Z_buffer.middleCols(e.first, e.cols);
  step.r = b;
  step.r.noalias() -= A * e.z;
  if (e.identity) {
    step.qr.compute(A);  // A Z = A
  } else {
    // posture and force rows: one column each (`sparsity`: A's rows as found once per search)
    if (sparsity)
      sparsity->product(A, Z, step.AZ);
    else
      sparse_rows_product(A, Z, step.AZ);
    // The step into u, apart from r (as the cascade's): r keeps its size, no reallocation.
    if (last && full_rank_step(step, step.r, step.u)) {
      e.z.noalias() += Z * step.u;
      work.used = StepWork::Used::full_rank;
      return;
    }
    step.qr.compute(step.AZ);
  }
  work.used = StepWork::Used::pivoted;
  const Eigen::Index rank = step.qr.rank();
  if (rank == 0) return;
  step.qr.solve(step.r, step.y);
  // Z Q: the first `rank` columns step (z += (Z Q)₁ y), the rest stay free (the next Z, the
  // window's tail). Where few columns or none stay free (the last level, whose null space no
  // level reads; a level that uses up what is left, or nearly), Z times the columns of Q that are
  // needed, Q [y | 0; 0 | I], costs less than applying every reflector to Z (tail_is_cheaper).
  const Eigen::Index left = last ? 0 : e.cols - rank;
  if (last || (!e.identity && tail_is_cheaper(n_, e.cols, std::min(b.size(), e.cols), left))) {
    work.tail.setZero(e.cols, 1 + left);
    work.tail.col(0).head(rank) = step.y;
    work.tail.bottomRightCorner(left, left).setIdentity();
    step.qr.apply_q_on_the_left(work.tail);
    e.z.noalias() += Z * work.tail.col(0);
    if (last) return;
    work.kept.noalias() = Z * work.tail.rightCols(left);
    Z.rightCols(left) = work.kept;
    e.first += rank;
    e.cols -= rank;
    return;
  }
  // Where Z is the identity, Q itself (formed from its reflectors, which skips the identity's
  // untouched corner)
  if (e.identity) {
    step.qr.q(work.Q);
    Z = work.Q;
    e.identity = false;
  } else {
    step.qr.apply_q_on_the_right(Z);
  }
  e.z.noalias() += Z.leftCols(rank) * step.y;
  e.first += rank;
  e.cols -= rank;
}

/// What solve_nullspace keeps from tick to tick (one set per thread, as the cascade's).
struct Buffers {
  std::array<ActiveSetSearch, 2> searches;  // the second for sequential's torque step
  SupportQR qr;
  Reparametrization change;
  std::vector<Level> levels;                         // rows over z (but for qdd_force)
  std::vector<Level> motion_levels, dynamic_levels;  // sequential's split of each level
  std::vector<const Level*> view;
  ForwardDynamics forward;
  Eigen::VectorXd contact_acceleration;
};

Buffers& buffers() {
  thread_local Buffers b;
  return b;
}

/// The rows of `in` whose force columns (from `nv` on) are all zero, over q̈ alone (`motion`),
/// and the others over x (`dynamic`): sequential's split of one level.
void split_level(const Level& in, Eigen::Index nv, Level& motion, Level& dynamic) {
  const auto split = [nv](const Eigen::MatrixXd& A, const Eigen::VectorXd& b, Eigen::MatrixXd& A_m,
                          Eigen::VectorXd& b_m, Eigen::MatrixXd& A_d, Eigen::VectorXd& b_d) {
    Eigen::Index moving = 0;
    for (Eigen::Index i = 0; i < A.rows(); ++i)
      moving += (A.row(i).tail(A.cols() - nv).array() != 0.0).any() ? 0 : 1;
    A_m.resize(moving, nv);
    b_m.resize(moving);
    A_d.resize(A.rows() - moving, A.cols());
    b_d.resize(A.rows() - moving);
    for (Eigen::Index i = 0, m = 0, d = 0; i < A.rows(); ++i) {
      if ((A.row(i).tail(A.cols() - nv).array() != 0.0).any()) {
        A_d.row(d) = A.row(i);
        b_d(d++) = b(i);
      } else {
        A_m.row(m) = A.row(i).head(nv);
        b_m(m++) = b(i);
      }
    }
  };
  split(in.A, in.b, motion.A, motion.b, dynamic.A, dynamic.b);
  split(in.C, in.d, motion.C, motion.d, dynamic.C, dynamic.d);
}

/// The start of search `i`: the last tick's active rows of that search, if any.
const ActiveSet* start_of(const HierarchyProblem& problem, std::size_t i) {
  return problem.active_start && problem.active_start->size() > i ? &(*problem.active_start)[i]
                                                                  : nullptr;
}

/// Hutter Table 4: q̈ first (eq. 48), then τ (eqs. 49-51), each search from its start; x is
/// what that τ does (constrained forward dynamics). Returns the number of searches (2).
std::size_t solve_sequential(const HierarchyProblem& problem, Buffers& b, Eigen::VectorXd& x) {
  const DynamicsTerms& terms = problem.terms;
  if (!terms.M)
    throw std::invalid_argument("formulation 'sequential' needs the model terms of the problem");
  const Eigen::Index nv = terms.M->rows();
  const std::size_t L = problem.levels.size();
  b.motion_levels.resize(L);
  b.dynamic_levels.resize(L);
  for (std::size_t k = 0; k < L; ++k)
    split_level(problem.levels[k], nv, b.motion_levels[k], b.dynamic_levels[k]);
  b.view.clear();
  for (const Level& level : b.motion_levels) b.view.push_back(&level);
  ActiveSetSearch& motion = b.searches[0];
  motion.run(b.view, nv, start_of(problem, 0), nullptr);
  torque_step(terms, problem.support, motion.z, b.qr, b.change);
  b.levels.resize(L);
  b.view.assign(1, &b.change.eom);
  for (std::size_t k = 0; k < L; ++k) {  // the dynamic rows over τ
    b.change.level(b.dynamic_levels[k], b.levels[k]);
    b.view.push_back(&b.levels[k]);
  }
  ActiveSetSearch& torque = b.searches[1];
  torque.run(b.view, terms.M->rows() - kBaseRows, start_of(problem, 1), nullptr);
  b.contact_acceleration.noalias() = b.qr.Js * motion.z;  // J_s q̈ of the kinematic step
  constrained_forward_dynamics(terms, problem.support, torque.z, b.contact_acceleration, b.forward,
                               x);
  return 2;
}

/// The formulations over one vector z (qdd_force, full, qdd_tau): x = T z + t.
std::size_t solve_reparametrized(const HierarchyProblem& problem, Buffers& b, Eigen::VectorXd& x) {
  reparametrize(problem, b.qr, b.change);
  const std::size_t L = problem.levels.size();
  b.view.assign(1, &b.change.eom);
  if (b.change.identity) {  // qdd_force: the problem's own rows
    for (const Level& level : problem.levels) b.view.push_back(&level);
  } else {
    b.levels.resize(L);
    for (std::size_t k = 0; k < L; ++k) {
      b.change.level(problem.levels[k], b.levels[k]);
      b.view.push_back(&b.levels[k]);
    }
  }
  // z is x itself under qdd_force: the last tick's x is a point to start from
  const Eigen::VectorXd* point = b.change.identity ? problem.x_start : nullptr;
  const Eigen::Index n = b.change.identity ? problem.dynamics_A.cols() : b.change.T.cols();
  ActiveSetSearch& search = b.searches[0];
  search.run(b.view, n, start_of(problem, 0), point);
  b.change.x_of(search.z, x);
  return 1;
}

}  // namespace

void solve_nullspace(const HierarchyProblem& problem, HierarchySolution& out) {
  Buffers& b = buffers();
  const std::size_t L = problem.levels.size();
  out.levels.assign(L, LevelStatus::projected);
  out.level_seconds.clear();
  out.qp_solves = 0;
  out.capped = false;
  out.projections = 0;
  out.message.clear();
  std::size_t searches = 0;
  try {
    searches = problem.formulation == "sequential" ? solve_sequential(problem, b, out.x)
                                                   : solve_reparametrized(problem, b, out.x);
  } catch (const SingularSystem& error) {
    out.ok = false;
    out.message = error.what();
    out.active_sets.clear();
    out.residuals.assign(L, 0.0);
    return;
  }
  out.active_sets.resize(searches);
  bool feasible = true;
  for (std::size_t i = 0; i < searches; ++i) {
    const ActiveSetSearch& search = b.searches[i];
    out.active_sets[i] = search.active;
    out.projections += search.projections;
    out.capped = out.capped || search.capped;
    feasible = feasible && (!search.capped || search.feasible);
  }
  if (out.capped)
    out.message = "nullspace: active set stopped at the cap of " + std::to_string(kMaxProjections) +
                  " hierarchy solves, at the best point found (" +
                  (feasible ? "feasible" : "still violating an inequality") + ")";
  out.residuals.resize(L);
  for (std::size_t k = 0; k < L; ++k) {
    const Level& level = problem.levels[k];
    out.residuals[k] = level.b.size() ? (level.A * out.x - level.b).norm() : 0.0;
  }
  out.ok = out.x.allFinite();
  if (!out.ok) out.message = "nullspace: non-finite solution";
}

ActiveSetSolution active_set_least_squares(const std::vector<Level>& levels, Eigen::Index n,
                                           int cap, const ActiveSet* start,
                                           const Eigen::VectorXd* point) {
  std::vector<const Level*> view;
  for (const Level& level : levels) view.push_back(&level);
  ActiveSetSearch search;
  search.run(view, n, start, point, cap);
  return {search.z, search.projections, search.capped, search.feasible, search.active};
}

HierarchySolution solve_nullspace(const HierarchyProblem& problem) {
  HierarchySolution out;
  solve_nullspace(problem, out);
  return out;
}

}  // namespace lab
