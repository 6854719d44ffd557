// lab/estimation/process.py in C++ (same equations, same order).
#include "estimation/process.hpp"

#include <pinocchio/spatial/explog.hpp>
#include <pinocchio/spatial/skew.hpp>

namespace lab::estimation {

void propagate(NominalState& x, const Eigen::Vector3d& accel, const Eigen::Vector3d& gyro,
               const Eigen::Vector3d& gravity, double dt) {
  const Eigen::Vector3d world_accel = x.rotation * (accel - x.accel_bias) + gravity;
  x.position += x.velocity * dt + 0.5 * world_accel * dt * dt;
  x.velocity += world_accel * dt;
  x.rotation = x.rotation * pinocchio::exp3(Eigen::Vector3d((gyro - x.gyro_bias) * dt));
}

void roll_feet(NominalState& x, const Eigen::Matrix3Xd& spins, const Eigen::Vector3d& gyro,
               const Eigen::VectorXd& radii, const Eigen::Array<bool, Eigen::Dynamic, 1>& stance,
               double dt) {
  const Eigen::Vector3d base = gyro - x.gyro_bias;
  for (Eigen::Index i = 0; i < spins.cols(); ++i) {
    if (!stance[i]) continue;
    const Eigen::Vector3d omega = x.rotation * (spins.col(i) + base);  // world
    x.feet.col(i) += dt * omega.cross(Eigen::Vector3d(0.0, 0.0, radii[i]));
  }
}

Transition transition(const NominalState& x, const Eigen::Vector3d& accel,
                      const Eigen::Vector3d& gyro, double dt) {
  const Eigen::Matrix3d& R = x.rotation;
  return {dt, -dt * R * pinocchio::skew(Eigen::Vector3d(accel - x.accel_bias)), -dt * R,
          pinocchio::exp3(Eigen::Vector3d((gyro - x.gyro_bias) * dt)).transpose()};
}

void propagate_covariance(const Transition& F, const ErrorLayout& layout, Eigen::MatrixXd& P,
                          Eigen::MatrixXd& work) {
  const int p = layout.p, v = layout.v, th = layout.theta, ba = layout.accel_bias(),
            bg = layout.gyro_bias();
  work = P;  // F P: only the rows p, v and θ change
  work.middleRows<3>(p).noalias() += F.dt * P.middleRows<3>(v);
  work.middleRows<3>(v).noalias() += F.v_theta * P.middleRows<3>(th);
  work.middleRows<3>(v).noalias() += F.v_ba * P.middleRows<3>(ba);
  work.middleRows<3>(th).noalias() = F.theta_theta * P.middleRows<3>(th);
  work.middleRows<3>(th).noalias() -= F.dt * P.middleRows<3>(bg);
  P = work;  // (F P) Fᵀ: the columns p, v and θ
  P.middleCols<3>(p).noalias() += F.dt * work.middleCols<3>(v);
  P.middleCols<3>(v).noalias() += work.middleCols<3>(th) * F.v_theta.transpose();
  P.middleCols<3>(v).noalias() += work.middleCols<3>(ba) * F.v_ba.transpose();
  P.middleCols<3>(th).noalias() = work.middleCols<3>(th) * F.theta_theta.transpose();
  P.middleCols<3>(th).noalias() -= F.dt * work.middleCols<3>(bg);
}

void process_noise(const EkfTuning& tuning, const Eigen::Array<bool, Eigen::Dynamic, 1>& stance,
                   double dt, const ErrorLayout& layout, Eigen::VectorXd& q) {
  q.setZero(layout.size);
  q.segment<3>(layout.v).setConstant(tuning.accel_noise * tuning.accel_noise * dt);
  q.segment<3>(layout.theta).setConstant(tuning.gyro_noise * tuning.gyro_noise * dt);
  q.segment<3>(layout.accel_bias())
      .setConstant(tuning.accel_bias_walk * tuning.accel_bias_walk * dt);
  q.segment<3>(layout.gyro_bias()).setConstant(tuning.gyro_bias_walk * tuning.gyro_bias_walk * dt);
  for (int i = 0; i < layout.n; ++i)
    if (stance[i])
      q.segment<3>(layout.foot(i)).setConstant(tuning.foot_slip * tuning.foot_slip * dt);
}

}  // namespace lab::estimation
