// Contact-consistent dynamics (lab/controller/contact_dynamics.py, Kim 2016 App. A, eqs. 27–32).
#include "contact_dynamics.hpp"

#include <algorithm>

#include "model.hpp"  // BASE_DOF

namespace lab {

// psd_pinv / _psd_pinv_and_null_space: one eigendecomposition of the symmetric part.
void PsdPinv::compute(const Eigen::Ref<const Eigen::MatrixXd>& matrix, double scale,
                      bool with_null_space) {
  const Eigen::Index n = matrix.rows();
  if (n == 0) {
    inverse_.resize(0, 0);
    rank_ = 0;
    return;
  }
  symmetric_ = 0.5 * (matrix + matrix.transpose());
  if (!with_null_space && decided_by_bounds(scale)) return;
  eigen_.compute(symmetric_);
  const auto& values = eigen_.eigenvalues();  // ascending, as numpy's eigh
  const double threshold =
      kContactRankTolerance * std::max(scale < 0.0 ? values[n - 1] : scale, 1e-300);
  Eigen::Index zero = 0;
  while (zero < n && !(values[zero] > threshold)) ++zero;
  rank_ = n - zero;
  const auto kept = eigen_.eigenvectors().rightCols(rank_);
  scaled_ = kept * values.tail(rank_).cwiseInverse().asDiagonal();
  inverse_.noalias() = scaled_.lazyProduct(kept.transpose());
}

bool PsdPinv::decided_by_bounds(double scale) {
  const Eigen::Index n = symmetric_.rows();
  const double frobenius = symmetric_.norm();  // >= |every eigenvalue|
  // The threshold, or (scale < 0: it depends on the largest eigenvalue) a bound above it.
  const double threshold =
      kContactRankTolerance * std::max(scale < 0.0 ? frobenius : scale, 1e-300);
  if (scale >= 0.0 && kPsdRankMargin * frobenius <= threshold) {  // every eigenvalue below it
    inverse_.setZero(n, n);
    rank_ = 0;
    return true;
  }
  llt_.compute(symmetric_);
  if (llt_.info() != Eigen::Success) return false;
  L_inverse_.setIdentity(n, n);
  llt_.matrixL().solveInPlace(L_inverse_);
  const double lambda_min_bound = 1.0 / L_inverse_.squaredNorm();  // 0 or NaN: not proven
  if (!(lambda_min_bound > kPsdRankMargin * threshold)) return false;
  inverse_.noalias() = L_inverse_.transpose().lazyProduct(L_inverse_);  // S^-1 = L^-T L^-1
  rank_ = n;
  return true;
}

Eigen::Block<const Eigen::MatrixXd, Eigen::Dynamic, Eigen::Dynamic, true> PsdPinv::null_space()
    const {
  const auto& vectors = eigen_.eigenvectors();
  return vectors.leftCols(inverse_.rows() - rank_);
}

// contact_dynamics.
void ContactDynamics::compute(const Eigen::Ref<const Eigen::MatrixXd>& M,
                              const Eigen::Ref<const Eigen::VectorXd>& h,
                              const Eigen::Ref<const Eigen::MatrixXd>& Js,
                              const Eigen::Ref<const Eigen::VectorXd>& drift) {
  const Eigen::Index nv = M.rows(), na = nv - BASE_DOF, ns = Js.rows();
  if (identity_.rows() != nv) identity_.setIdentity(nv, nv);
  llt_.compute(M);
  inertia_inverse = llt_.solve(identity_);  // A⁻¹ (M is symmetric positive definite)
  const Eigen::MatrixXd& Minv = inertia_inverse;
  Ns_ = identity_;
  if (ns) {
    Minv_JsT_.noalias() = Minv.lazyProduct(Js.transpose());
    scratch_.noalias() = Js.lazyProduct(Minv_JsT_);
    lambda_s_.compute(scratch_);                                   // Λ_s = (J_s A⁻¹ J_sᵀ)⁻¹
    Jbar_.noalias() = Minv_JsT_.lazyProduct(lambda_s_.inverse());  // J̄_s, eq. 31
    Ns_.noalias() -= Jbar_.lazyProduct(Js);                        // eq. 32
    Lambda_drift_.noalias() = lambda_s_.inverse() * drift;
  } else {
    Jbar_.resize(nv, 0);
    Lambda_drift_.resize(0);
  }
  qdd_of_torque.noalias() = Minv.lazyProduct(Ns_.bottomRows(na).transpose());  // eq. 30
  force_free = h;  // scratch for N_sᵀ h + J_sᵀ Λ_s J̇_s v
  qdd_free.noalias() = Ns_.transpose() * force_free;
  if (ns) qdd_free.noalias() += Js.transpose() * Lambda_drift_;
  force_free = qdd_free;
  qdd_free.noalias() = -Minv * force_free;
  phi.noalias() = Ns_.bottomRows(na).lazyProduct(qdd_of_torque);  // Φ*
  phi_pinv_.compute(phi, -1.0, true);  // its null space is the internal-force torques'
  // λ = J̄_sᵀ (Uᵀτ − h) + Λ_s J̇_s v (eq. 29) and F = −λ.
  force_of_torque = -Jbar_.bottomRows(na).transpose();
  force_free.noalias() = Jbar_.transpose() * h;
  force_free -= Lambda_drift_;
}

void ContactDynamics::contact_consistent_jacobian(const Eigen::Ref<const Eigen::MatrixXd>& J,
                                                  Eigen::MatrixXd& out) const {
  JB_.noalias() = J.lazyProduct(qdd_of_torque);
  out.noalias() = JB_.lazyProduct(phi_pinv());
}

}  // namespace lab
