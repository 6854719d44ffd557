// The optimization vectors of Hutter 2014 §4 as changes of variables of one hierarchy (mirrors
// lab/controller/hierarchy/formulations.py, whose docstring derives each one):
//   qdd_force  z = [q̈, F]     (Table 3): the problem's own rows, forces out of support held at 0
//   full       z = [q̈, τ, F]  (Table 1): [M, −Sᵀ, −J_sᵀ] z = −h
//   qdd_tau    z = [q̈, τ]     (Table 2): Q_uᵀ [M, −Sᵀ] z = −Q_uᵀ h, F from eq. 28
//   sequential q̈ first, then τ (Table 4): torque_step and nullspace.cpp
// Signs follow the lab's M q̈ + h − J_sᵀ F = Sᵀ τ, so eq. 28 reads F_s = R⁻¹ Q_cᵀ (M q̈ + h − Sᵀ τ).
#pragma once

#include <Eigen/Dense>
#include <stdexcept>
#include <string>

#include "hierarchy/problem.hpp"

namespace lab {

/// A system that should be invertible was not (linalg.py SingularSystem): the tick fails.
class SingularSystem : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Whether `name` is one of the four formulations (formulations.py FORMULATIONS).
bool is_formulation(const std::string& name);

/// x = T z + t, with the formulation's equations of motion `eom` as rows over z
/// (formulations.py Reparametrization). `identity` marks qdd_force's T = I, t = 0.
struct Reparametrization {
  Eigen::MatrixXd T;
  Eigen::VectorXd t;
  Level eom;
  bool identity = false;
  Eigen::MatrixXd MS;    // scratch: [M, −Sᵀ] (qdd_tau)
  Eigen::VectorXd bias;  // scratch: M q̈ + h (torque_step)

  /// The same rows over z (Reparametrization.level), into `out`.
  void level(const Level& in, Level& out) const;
  /// x = T z + t.
  void x_of(const Eigen::VectorXd& z, Eigen::VectorXd& x) const;
};

/// J_sᵀ = Q_c R, Q_u spanning the rest; `force_map` K gives F = K (M q̈ + h − Sᵀ τ), eq. 28
/// (formulations.py SupportQR).
struct SupportQR {
  Eigen::MatrixXd Qc, Qu, force_map;
  Eigen::MatrixXd Js, Q, K_support;  // the support rows of J_c; scratch: Q, K's support rows
  Eigen::HouseholderQR<Eigen::MatrixXd> qr;  // of J_sᵀ
  Eigen::VectorXd workspace;
};

/// The QR decomposition of the support Jacobian (Hutter §4.2.1, formulations.py support_qr);
/// throws SingularSystem when it is singular.
void support_qr(const DynamicsTerms& terms, const Eigen::Array<bool, Eigen::Dynamic, 1>& support,
                SupportQR& out);

/// The change of variables of `problem.formulation` (qdd_force, full or qdd_tau) into `out`
/// (formulations.py reparametrize); `qr` is scratch.
void reparametrize(const HierarchyProblem& problem, SupportQR& qr, Reparametrization& out);

/// Step 2 of the sequential method (Table 4): z = τ with q̈ fixed, the equations of motion
/// Q_uᵀ Sᵀ τ = Q_uᵀ (M q̈ + h) (eq. 49) (formulations.py torque_step).
void torque_step(const DynamicsTerms& terms, const Eigen::Array<bool, Eigen::Dynamic, 1>& support,
                 const Eigen::VectorXd& qdd, SupportQR& qr, Reparametrization& out);

/// Scratch of constrained_forward_dynamics.
struct ForwardDynamics {
  Eigen::MatrixXd K, Js;
  Eigen::VectorXd rhs, solution;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;
};

/// x = [q̈, F] that τ produces with the support feet at the given accelerations J_s q̈:
/// [M −J_sᵀ; J_s 0] [q̈; F_s] = [Sᵀ τ − h; J_s q̈_kin] (formulations.py
/// constrained_forward_dynamics); throws SingularSystem when that system is singular.
void constrained_forward_dynamics(const DynamicsTerms& terms,
                                  const Eigen::Array<bool, Eigen::Dynamic, 1>& support,
                                  const Eigen::VectorXd& tau,
                                  const Eigen::VectorXd& contact_acceleration,
                                  ForwardDynamics& scratch, Eigen::VectorXd& x);

}  // namespace lab
