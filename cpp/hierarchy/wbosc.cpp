// Whole-Body Operational Space Control (Kim 2016 App. A; Sentis 2007, 2010): closed form, no QP.
// Mirrors lab/controller/hierarchy/wbosc.py: the feet in support are held still by the
// contact-consistent dynamics (contact_dynamics.cpp), the motion levels are prioritized in
// Sentis's dynamically consistent way over the torques, the rows over F only (internal force,
// force regularizer) are met by torques in the null space of Φ* (eqs. 38–43), a foot in a
// contact transition carries w times its dual-contact force (eqs. 9–10), and the stack's
// inequalities are evaluated at the result and reported, not enforced.
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "contact_dynamics.hpp"
#include "hierarchy/linalg.hpp"  // kBaseRows
#include "hierarchy/problem.hpp"

namespace lab {
namespace {

constexpr double kViolationTolerance = 1e-6;  // wbosc.py VIOLATION_TOLERANCE

/// One level's rows split into motion (over q̈) and force (over F) rows, and the products of one
/// pass; kept per level so that a tick allocates nothing while the shapes stay.
struct LevelWork {
  Eigen::MatrixXd J, A_F, A_s, J_star, J_prior, J_Minv, G, full, phi_JT, sensitivity, gram,
      step_map;
  Eigen::VectorXd b, b_F, error;
  PsdPinv pinv;
  bool motion = false, force = false;
};

/// The storage of one pass of _solve: its contact-consistent dynamics and the levels' work.
struct Pass {
  ContactDynamics dyn;
  std::vector<LevelWork> levels;
  std::vector<Eigen::Index> support;  // rows of F in support
  Eigen::MatrixXd Js, null, null_step, room, room_step, Z_room;
  Eigen::VectorXd drift_s, tau, w, qdd, forces, scratch, scratch_na;
};

/// _split: the level's rows over q̈ only and over F only; a row over both is refused.
void split(const Level& level, Eigen::Index nv, std::size_t index, LevelWork& work) {
  const Eigen::Index m = level.b.size(), nf = level.A.cols() - nv;
  Eigen::Index motion = 0, force = 0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const bool on_qdd = (level.A.row(i).head(nv).array() != 0.0).any();
    const bool on_force = (level.A.row(i).tail(nf).array() != 0.0).any();
    if (on_qdd && on_force)
      throw std::invalid_argument("wbosc: level " + std::to_string(index) +
                                  " has rows over both q̈ and F");
    motion += on_qdd;
    force += on_force;
  }
  work.J.resize(motion, nv);
  work.b.resize(motion);
  work.A_F.resize(force, nf);
  work.b_F.resize(force);
  motion = force = 0;
  for (Eigen::Index i = 0; i < m; ++i) {
    if ((level.A.row(i).head(nv).array() != 0.0).any()) {
      work.J.row(motion) = level.A.row(i).head(nv);
      work.b[motion++] = level.b[i];
    } else if ((level.A.row(i).tail(nf).array() != 0.0).any()) {
      work.A_F.row(force) = level.A.row(i).tail(nf);
      work.b_F[force++] = level.b[i];
    }
  }
  work.motion = motion > 0;
  work.force = force > 0;
}

/// _solve: the WBOSC torques for the contact-consistent dynamics of the rows `flags` of F (with
/// bias forces `bias`), and the x they give; `moved` flags the levels that moved.
void solve_pass(const HierarchyProblem& problem, const Eigen::VectorXd& bias,
                const Eigen::Array<bool, Eigen::Dynamic, 1>& flags, Pass& pass,
                std::vector<char>& moved, LevelClock& clock, Eigen::VectorXd& x) {
  const DynamicsTerms& terms = problem.terms;
  const Eigen::Index nv = terms.M->rows(), na = nv - kBaseRows;
  pass.support.clear();
  for (Eigen::Index i = 0; i < flags.size(); ++i)
    if (flags[i]) pass.support.push_back(i);
  const auto ns = static_cast<Eigen::Index>(pass.support.size());
  pass.Js.resize(ns, nv);
  pass.drift_s.resize(ns);
  for (Eigen::Index r = 0; r < ns; ++r) {
    pass.Js.row(r) = terms.Jc->row(pass.support[r]);
    pass.drift_s[r] = (*terms.drift)[pass.support[r]];
  }
  ContactDynamics& dyn = pass.dyn;
  dyn.compute(*terms.M, bias, pass.Js, pass.drift_s);
  pass.levels.resize(problem.levels.size());
  moved.assign(problem.levels.size(), 0);

  // Motion levels, highest priority first (Sentis's prioritized WBOSC).
  pass.tau.setZero(na);
  pass.null.setIdentity(na, na);  // N*_p
  for (std::size_t k = 0; k < problem.levels.size(); ++k) {
    LevelWork& work = pass.levels[k];
    split(problem.levels[k], nv, k, work);
    if (work.motion) {
      dyn.contact_consistent_jacobian(work.J, work.J_star);
      work.J_prior.noalias() = work.J_star.lazyProduct(pass.null);  // J*_{k|p}
      work.J_Minv.noalias() = work.J.lazyProduct(dyn.inertia_inverse);
      const double scale = work.J_Minv.cwiseProduct(work.J).sum();  // trace J A⁻¹ Jᵀ
      work.full.noalias() = work.J_prior.lazyProduct(dyn.phi);
      work.G.noalias() = work.full.lazyProduct(work.J_prior.transpose());
      work.pinv.compute(work.G, scale);  // Λ*_{k|p}
      if (work.pinv.rank()) {
        moved[k] = 1;
        pass.qdd = dyn.qdd_free;
        pass.qdd.noalias() += dyn.qdd_of_torque * pass.tau;
        work.error = work.b;
        work.error.noalias() -= work.J * pass.qdd;
        pass.scratch.noalias() = work.pinv.inverse() * work.error;
        pass.tau.noalias() += work.J_prior.transpose() * pass.scratch;
        // N*_p ← N*_p − Φ* J*_{k|p}ᵀ Λ*_{k|p} J*_{k|p}
        work.step_map.noalias() = work.pinv.inverse().lazyProduct(work.J_prior);
        work.phi_JT.noalias() = dyn.phi.lazyProduct(work.J_prior.transpose());
        pass.null_step.noalias() = work.phi_JT.lazyProduct(work.step_map);
        pass.null -= pass.null_step;
      }
    }
    clock.lap(k);
  }

  // Force levels in the internal-force torques (null space of Φ*, eqs. 38–43).
  const auto Z = dyn.internal_basis();
  const Eigen::Index kz = Z.cols();
  pass.room.setIdentity(kz, kz);
  pass.w.setZero(kz);
  for (std::size_t k = 0; k < problem.levels.size(); ++k) {
    LevelWork& work = pass.levels[k];
    if (!work.force) continue;
    work.A_s.resize(work.A_F.rows(), ns);
    for (Eigen::Index r = 0; r < ns; ++r) work.A_s.col(r) = work.A_F.col(pass.support[r]);
    work.full.noalias() =
        work.A_s.lazyProduct(dyn.force_of_torque);  // how every torque moves these forces
    pass.Z_room.noalias() = Z.lazyProduct(pass.room);
    work.sensitivity.noalias() = work.full.lazyProduct(pass.Z_room);
    work.gram.noalias() = work.sensitivity.transpose().lazyProduct(work.sensitivity);
    work.pinv.compute(work.gram, work.full.squaredNorm());
    if (work.pinv.rank() == 0) continue;
    moved[k] = 1;
    pass.scratch_na = pass.tau;
    pass.scratch_na.noalias() += Z * pass.w;
    pass.forces = dyn.force_free;
    pass.forces.noalias() += dyn.force_of_torque * pass.scratch_na;
    work.error = work.b_F;
    work.error.noalias() -= work.A_s * pass.forces;
    work.step_map.noalias() = pass.room.lazyProduct(work.pinv.inverse());
    pass.scratch.noalias() = work.sensitivity.transpose() * work.error;
    pass.w.noalias() += work.step_map * pass.scratch;
    // room ← room (I − gram⁺ sᵀ s)
    pass.room_step.noalias() = work.step_map.lazyProduct(work.gram);
    pass.room -= pass.room_step;
    clock.lap(k);
  }
  pass.tau.noalias() += Z * pass.w;

  x.setZero(problem.dynamics_A.cols());
  x.head(nv) = dyn.qdd_free;
  x.head(nv).noalias() += dyn.qdd_of_torque * pass.tau;
  pass.forces = dyn.force_free;
  pass.forces.noalias() += dyn.force_of_torque * pass.tau;
  for (Eigen::Index r = 0; r < ns; ++r) x[nv + pass.support[r]] = pass.forces[r];
}

/// The first `n` entries of `buffer`, which grows to hold them (and never shrinks: levels of
/// different sizes share it without allocating).
Eigen::VectorXd::SegmentReturnType head_of(Eigen::VectorXd& buffer, Eigen::Index n) {
  if (buffer.size() < n) buffer.resize(n);
  return buffer.head(n);
}

/// _violations: one line per constraint of the stack with a row C x − d above tolerance.
void find_violations(const HierarchyProblem& problem, const Eigen::VectorXd& x,
                     Eigen::VectorXd& buffer, std::vector<std::string>& out) {
  out.clear();
  for (std::size_t k = 0; k < problem.levels.size(); ++k) {
    const Level& level = problem.levels[k];
    if (!level.d.size()) continue;
    auto excess = head_of(buffer, level.d.size());  // C x − d
    excess.noalias() = level.C * x;
    excess -= level.d;
    Eigen::Index start = 0;
    for (const auto& [name, count] : level.constraint_rows) {
      const double worst = count ? excess.segment(start, count).maxCoeff() : -INFINITY;
      if (worst > kViolationTolerance) {
        char value[32];
        std::snprintf(value, sizeof value, "%.3g", worst);
        out.push_back("level " + std::to_string(k) + " " + name + ": exceeded by " + value);
      }
      start += count;
    }
  }
}

}  // namespace

void solve_wbosc(const HierarchyProblem& problem, HierarchySolution& out) {
  thread_local Pass dual, main;
  thread_local std::vector<char> moved;
  thread_local Eigen::VectorXd bias, x_dual, external, scratch;
  thread_local Eigen::Array<bool, Eigen::Dynamic, 1> changing, support;
  thread_local std::vector<Eigen::Index> leaving;
  const DynamicsTerms& terms = problem.terms;
  const std::size_t n_levels = problem.levels.size();
  if (!terms.M || !terms.h || !terms.Jc || !terms.drift ||
      terms.Jc->rows() != problem.support.size() || terms.drift->size() != problem.support.size())
    throw std::invalid_argument("wbosc needs the dynamics terms M, h, J_c and J̇_c v");
  const Eigen::Index nv = terms.M->rows();
  LevelClock clock(out.level_seconds, n_levels);
  bias = *terms.h;
  support = problem.support;
  leaving.clear();
  if (terms.transition.size() == support.size()) {
    changing = support && terms.transition.array().isFinite();
    if (changing.any()) {
      solve_pass(problem, bias, support, dual, moved, clock, x_dual);
      external.resize(changing.count());
      for (Eigen::Index i = 0; i < changing.size(); ++i)
        if (changing[i]) {  // f = w f_dual (eqs. 9–10), a known external force on the foot
          const auto j = static_cast<Eigen::Index>(leaving.size());
          external[j] = terms.transition[i] * x_dual[nv + i];
          bias -= terms.Jc->row(i).transpose() * external[j];
          leaving.push_back(i);
        }
      support = support && !changing;
    }
  }
  solve_pass(problem, bias, support, main, moved, clock, out.x);
  for (std::size_t j = 0; j < leaving.size(); ++j)
    out.x[nv + leaving[j]] = external[static_cast<Eigen::Index>(j)];
  out.levels.resize(n_levels);
  out.residuals.resize(n_levels);
  for (std::size_t k = 0; k < n_levels; ++k) {
    const Level& level = problem.levels[k];
    out.levels[k] = level.b.size() && !moved[k] ? LevelStatus::no_freedom : LevelStatus::exact;
    if (!level.b.size()) {
      out.residuals[k] = 0.0;
      continue;
    }
    auto residual = head_of(scratch, level.b.size());  // A x − b
    residual.noalias() = level.A * out.x;
    residual -= level.b;
    out.residuals[k] = residual.norm();
  }
  find_violations(problem, out.x, scratch, out.violations);
  out.qp_solves = 0;
  out.ok = true;
  out.message.clear();
}

HierarchySolution solve_wbosc(const HierarchyProblem& problem) {
  HierarchySolution out;
  solve_wbosc(problem, out);
  return out;
}

}  // namespace lab
