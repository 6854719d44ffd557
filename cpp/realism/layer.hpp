// lab/realism/layer.py in C++: sensors, delays and actuators between the plant and the
// controller. The native tick calls measure(q, v) before the controller and actuate(τ, q, v)
// after it, with the plant's true (q, v) (docs/realism.md, "The native tick").
#pragma once

#include <Eigen/Core>
#include <memory>
#include <utility>

#include "realism/actuators.hpp"
#include "realism/delays.hpp"
#include "realism/knobs.hpp"
#include "realism/sensors.hpp"

namespace lab::realism {

class Layer {
 public:
  Layer(const Knobs& knobs, int na, double dt);
  /// A new run from configuration q at rest, the actuators carrying `tau` (N m).
  void reset(const Eigen::VectorXd& q, const Eigen::VectorXd& tau);
  /// The state the controller reads this tick, from the true (q, v).
  std::pair<Eigen::VectorXd, Eigen::VectorXd> measure(const Eigen::VectorXd& q,
                                                      const Eigen::VectorXd& v);
  /// The joint torques the plant applies for the controller's `command`, given the true state.
  Eigen::VectorXd actuate(const Eigen::VectorXd& command, const Eigen::VectorXd& q,
                          const Eigen::VectorXd& v);
  bool ideal() const { return ideal_; }
  std::uint64_t tick() const { return tick_; }

 private:
  Knobs knobs_;
  int na_, width_;
  Imu imu_;
  Encoders encoders_;
  DelayLine state_delay_, command_delay_;
  std::unique_ptr<FirstOrderTorque> bandwidth_;
  std::unique_ptr<SeriesElastic> sea_;
  bool noisy_, ideal_;
  std::uint64_t tick_ = 0;
  Eigen::VectorXd noise_;
};

}  // namespace lab::realism
