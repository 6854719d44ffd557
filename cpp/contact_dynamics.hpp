// Contact-consistent dynamics of a floating-base robot (mirrors lab/controller/contact_dynamics.py,
// Kim 2016 App. A, eqs. 27–32): with the feet in support held still (J_s q̈ + J̇_s v = 0), the
// joint torques τ decide q̈ and the reaction forces in closed form. Lab conventions: M q̈ + h −
// J_sᵀ F = Uᵀ τ with F the force of the ground on the robot (Kim's λ is −F).
#pragma once

#include <Eigen/Dense>

namespace lab {

/// Relative size below which an eigenvalue of Φ* (or of a task's Λ*⁻¹) counts as zero.
constexpr double kContactRankTolerance = 1e-9;

/// Safety factor of PsdPinv's shortcuts on the bounds they compare (rounding is ~1e-16 of them).
constexpr double kPsdRankMargin = 1e3;

/// The pseudo-inverse of a symmetric positive semi-definite matrix, its rank and an orthonormal
/// basis of its null space, from one eigendecomposition (psd_pinv and _psd_pinv_and_null_space):
/// eigenvalues below kContactRankTolerance times `scale` (the largest eigenvalue when scale < 0)
/// count as zero. One object per use keeps its storage: no allocation while the size stays.
///
/// Without the null space (`with_null_space` false) two cases skip the eigendecomposition and
/// decide the rank as it would, proven by bounds with a margin of kPsdRankMargin: every
/// eigenvalue is at most ||S||_F, so ||S||_F that far below the threshold is rank 0; and an LLT
/// S = L L^T gives lambda_min >= 1 / ||L^-1||_F^2, so that far above it is full rank, the inverse
/// L^-T L^-1. Between the two (a level partly used up above) the eigendecomposition decides.
class PsdPinv {
 public:
  /// Factorizes the symmetric part of `matrix`.
  void compute(const Eigen::Ref<const Eigen::MatrixXd>& matrix, double scale = -1.0,
               bool with_null_space = false);
  const Eigen::MatrixXd& inverse() const { return inverse_; }
  /// The eigenvectors of the eigenvalues counted as zero (columns); after a compute with
  /// `with_null_space` only.
  Eigen::Block<const Eigen::MatrixXd, Eigen::Dynamic, Eigen::Dynamic, true> null_space() const;
  Eigen::Index rank() const { return rank_; }

 private:
  /// The shortcuts above; false when neither applies.
  bool decided_by_bounds(double scale);

  Eigen::MatrixXd symmetric_, inverse_, scaled_, L_inverse_;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  Eigen::Index rank_ = 0;
};

/// The maps of eqs. 28–32 at one state for the supporting contacts' rows J_s (ContactDynamics):
/// q̈ = B τ + q̈₀ (eq. 30), F = D τ + F₀ on the support rows (eq. 29, F = −λ), A⁻¹, Φ* = U N_s A⁻¹
/// N_sᵀ Uᵀ, its pseudo-inverse and an orthonormal basis of its null space (the torques that
/// move nothing: the range of L*, eq. 38). Storage is kept from call to call.
class ContactDynamics {
 public:
  /// The maps for inertia M, bias forces h, support Jacobian Js (may have no rows) and its drift
  /// J̇_s v (contact_dynamics).
  void compute(const Eigen::Ref<const Eigen::MatrixXd>& M,
               const Eigen::Ref<const Eigen::VectorXd>& h,
               const Eigen::Ref<const Eigen::MatrixXd>& Js,
               const Eigen::Ref<const Eigen::VectorXd>& drift);

  /// J* = J (U N_s)‾ (eq. 33) into `out`: the task Jacobian over the actuated joints, J B = J* Φ*.
  void contact_consistent_jacobian(const Eigen::Ref<const Eigen::MatrixXd>& J,
                                   Eigen::MatrixXd& out) const;

  Eigen::MatrixXd inertia_inverse;  // A⁻¹
  Eigen::MatrixXd qdd_of_torque;    // B (nv × na)
  Eigen::VectorXd qdd_free;         // q̈₀
  Eigen::MatrixXd force_of_torque;  // D (n_s × na)
  Eigen::VectorXd force_free;       // F₀
  Eigen::MatrixXd phi;              // Φ*
  const Eigen::MatrixXd& phi_pinv() const { return phi_pinv_.inverse(); }
  Eigen::Block<const Eigen::MatrixXd, Eigen::Dynamic, Eigen::Dynamic, true> internal_basis() const {
    return phi_pinv_.null_space();
  }

 private:
  Eigen::LLT<Eigen::MatrixXd> llt_;
  PsdPinv lambda_s_, phi_pinv_;
  Eigen::MatrixXd identity_, Minv_JsT_, Jbar_, Ns_, scratch_;
  Eigen::VectorXd Lambda_drift_;
  mutable Eigen::MatrixXd JB_;
};

}  // namespace lab
