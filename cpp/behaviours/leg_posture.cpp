#include "behaviours/leg_posture.hpp"

#include <algorithm>
#include <pinocchio/spatial/explog.hpp>

namespace lab {
namespace {
constexpr double kClikGain = 10.0;  // 1/s, P of eqs. 30-31 (leg_posture.py CLIK_GAIN)
constexpr int kBaseDof = 6;
}  // namespace

void leg_posture_velocity(const LegPostureInput& in, Eigen::Map<RowMatrixX3> previous_rotations,
                          Eigen::Map<Eigen::VectorXd> velocity) {
  thread_local Eigen::VectorXd rate;
  thread_local Eigen::MatrixXd JJt;
  thread_local Eigen::LLT<Eigen::MatrixXd> llt;
  const Eigen::Index n = in.contact_positions.rows();
  const Eigen::Vector3d& w = in.base_angular_velocity;
  rate.resize(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d r = in.contact_positions.row(i).transpose() - in.base_position;
    Eigen::Vector3d rate_i;
    if (in.stance[i]) {
      // A stance foot moves against the commanded base twist, and by P ΔH_bl (eq. 31) ...
      rate_i = -(in.base_velocity + w.cross(r));
      rate_i.z() -= kClikGain * in.height_error;
      if (in.dt > 0.0) {  // ... plus the sphere's rolling, ω_f × ρ ẑ = ρ [ω_y, −ω_x, 0]
        const Eigen::Matrix3d turned = in.contact_rotations.middleRows<3>(3 * i) *
                                       previous_rotations.middleRows<3>(3 * i).transpose();
        const Eigen::Vector3d angle = pinocchio::log3(turned);  // ω_f dt
        const double roll = in.radius(i) / in.dt;
        rate_i.x() += roll * angle.y();
        rate_i.y() -= roll * angle.x();
      }
    } else {  // a swinging foot tracks its swing trajectory relative to the base (eq. 30)
      const Eigen::Vector3d r_d = in.foot_position.row(i).transpose() - in.base_position;
      rate_i = in.foot_velocity.row(i).transpose() - in.base_velocity - w.cross(r_d) +
               kClikGain * (r_d - r);
    }
    rate.segment<3>(3 * i) = rate_i;
  }
  previous_rotations = in.contact_rotations;
  // q̇ = Jᵀ (J Jᵀ + λ² I)⁻¹ ṙ of every leg in one system (one Cholesky solve).
  const auto J = in.contact_jacobian.rightCols(in.contact_jacobian.cols() - kBaseDof);
  JJt.noalias() = J * J.transpose();
  JJt.diagonal().array() += in.damping * in.damping;
  llt.compute(JJt);
  rate = llt.solve(rate);
  velocity.noalias() = J.transpose() * rate;
}

}  // namespace lab

namespace lab {
namespace {
constexpr double kMaxCarry = 0.01;  // m, the largest base lag a touchdown carries over

/// The feet's 3 rows of leg `leg`'s joints (J_c[force_slices[leg], BASE_DOF + joints]).
Eigen::Matrix3Xd leg_jacobian(const Eigen::Ref<const RowMatrixX>& contact_jacobian,
                              const std::vector<int>& joints, int leg) {
  Eigen::Matrix3Xd J(3, static_cast<Eigen::Index>(joints.size()));
  for (std::size_t c = 0; c < joints.size(); ++c)
    J.col(static_cast<Eigen::Index>(c)) =
        contact_jacobian.block<3, 1>(3 * leg, kBaseDof + joints[c]);
  return J;
}
}  // namespace

void leg_posture_restart(const Eigen::Ref<const RowMatrixX>& contact_jacobian,
                         const Eigen::Ref<const Eigen::VectorXd>& joint_positions,
                         const std::vector<std::vector<int>>& joints, int leg,
                         const std::vector<int>& carry_from, double damping,
                         Eigen::Ref<Eigen::VectorXd> position) {
  for (int j : joints[leg]) position(j) = joint_positions(j);
  if (carry_from.empty()) return;
  Eigen::Vector3d lag = Eigen::Vector3d::Zero();
  const double n = static_cast<double>(carry_from.size());
  for (int k : carry_from) {
    const std::vector<int>& jk = joints[k];
    Eigen::VectorXd behind(static_cast<Eigen::Index>(jk.size()));
    for (std::size_t c = 0; c < jk.size(); ++c)
      behind(static_cast<Eigen::Index>(c)) = position(jk[c]) - joint_positions(jk[c]);
    lag += (leg_jacobian(contact_jacobian, jk, k) * behind) / n;
  }
  lag.z() = 0.0;
  lag *= std::min(1.0, kMaxCarry / std::max(lag.norm(), 1e-12));
  // J⁻¹ lag for the point foot's 3-row Jacobian, damped: Jᵀ (J Jᵀ + λ² I)⁻¹ lag.
  const Eigen::Matrix3Xd J = leg_jacobian(contact_jacobian, joints[leg], leg);
  Eigen::Matrix3d JJt = J * J.transpose();
  JJt.diagonal().array() += damping * damping;
  const Eigen::VectorXd step = J.transpose() * JJt.partialPivLu().solve(lag);
  for (std::size_t c = 0; c < joints[leg].size(); ++c)
    position(joints[leg][c]) += step(static_cast<Eigen::Index>(c));
}

}  // namespace lab
