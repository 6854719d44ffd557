// lab/realism/actuators.py in C++ (same arithmetic, same order).
#include "realism/actuators.hpp"

#include <cmath>

namespace lab::realism {

FirstOrderTorque::FirstOrderTorque(const Knobs& knobs, int na, double dt)
    : alpha_(1.0 - std::exp(-2.0 * M_PI * knobs.torque_bandwidth_hz * dt)),
      tau_(Eigen::VectorXd::Zero(na)) {}

Eigen::VectorXd FirstOrderTorque::apply(const Eigen::VectorXd& command) {
  tau_ += alpha_ * (command - tau_);
  return tau_;
}

SeriesElastic::SeriesElastic(const Knobs& knobs, int na, double dt)
    : k_(knobs.sea_stiffness),
      inertia_(knobs.sea_motor_inertia),
      kp_(knobs.sea_kp),
      kd_(knobs.sea_kd),
      h_(dt / kSeaSubsteps),
      theta_(Eigen::VectorXd::Zero(na)),
      omega_(Eigen::VectorXd::Zero(na)) {}

void SeriesElastic::reset(const Eigen::VectorXd& qj, const Eigen::VectorXd& tau) {
  theta_ = qj + tau / k_;
  omega_.setZero();
}

Eigen::VectorXd SeriesElastic::apply(const Eigen::VectorXd& command,
                                     const Eigen::Ref<const Eigen::VectorXd>& qj,
                                     const Eigen::Ref<const Eigen::VectorXd>& vj) {
  const Eigen::VectorXd drive = command + kp_ * command / k_ + kd_ * vj;
  const double scale = 1.0 / (inertia_ + h_ * kd_ + h_ * h_ * (kp_ + k_));
  for (int i = 0; i < kSeaSubsteps; ++i) {  // implicit Euler on (θ, ω), the joint held
    omega_ = scale * (inertia_ * omega_ + h_ * (drive - (kp_ + k_) * (theta_ - qj)));
    theta_ = theta_ + h_ * omega_;
  }
  return k_ * (theta_ - qj);
}

}  // namespace lab::realism
