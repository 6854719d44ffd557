#include "behaviours/leg_posture.hpp"

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
