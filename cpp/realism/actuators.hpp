// lab/realism/actuators.py in C++: first-order torque bandwidth and the series elastic actuator.
#pragma once

#include <Eigen/Core>

#include "realism/knobs.hpp"

namespace lab::realism {

constexpr int kSeaSubsteps = 10;  // implicit Euler steps per tick, as SEA_SUBSTEPS

/// τ̇ = 2π f (τ_cmd − τ), exact for a command held over the tick.
class FirstOrderTorque {
 public:
  FirstOrderTorque(const Knobs& knobs, int na, double dt);
  void reset(const Eigen::VectorXd& tau) { tau_ = tau; }
  Eigen::VectorXd apply(const Eigen::VectorXd& command);

 private:
  double alpha_;
  Eigen::VectorXd tau_;
};

/// J θ̈ = τ_cmd + K_p (δ_d − δ) + K_d (q̇ − θ̇) − k δ, δ = θ − q, δ_d = τ_cmd / k; joint
/// torque k δ. The layer integrates the motor state (the joint held over the tick).
class SeriesElastic {
 public:
  SeriesElastic(const Knobs& knobs, int na, double dt);
  void reset(const Eigen::VectorXd& qj, const Eigen::VectorXd& tau);
  Eigen::VectorXd apply(const Eigen::VectorXd& command, const Eigen::Ref<const Eigen::VectorXd>& qj,
                        const Eigen::Ref<const Eigen::VectorXd>& vj);

 private:
  double k_, inertia_, kp_, kd_, h_;
  Eigen::VectorXd theta_, omega_;
};

}  // namespace lab::realism
