// lab/realism/accelerometer.py in C++: the IMU's accelerometer the state estimator reads (the
// specific force at the base origin from the plant's true motion, its noise from the seed's own
// stream, through the measurement delay; see there for the model).
#pragma once

#include <Eigen/Core>
#include <cstdint>

#include "realism/delays.hpp"

namespace lab::realism {

constexpr std::uint64_t kAccelStream = 0x616363656CULL;  // "accel", apart from the layer's
constexpr int kAccelDraws = 6;                           // white 3, bias walk 3

class Accelerometer {
 public:
  /// `noise` (m/s²/√Hz) and `bias_walk` (m/s³/√Hz) the knobs accel_noise and accel_bias_walk.
  Accelerometer(double noise, double bias_walk, int delay, std::uint64_t seed, double dt,
                const Eigen::Vector3d& gravity);
  /// A new run from the true state (q, v): no bias, no reading delayed yet.
  void reset(const Eigen::Ref<const Eigen::VectorXd>& q,
             const Eigen::Ref<const Eigen::VectorXd>& v);
  /// The reading (m/s², base frame) at the true state (q, v) of this tick.
  Eigen::Vector3d measure(const Eigen::Ref<const Eigen::VectorXd>& q,
                          const Eigen::Ref<const Eigen::VectorXd>& v);

 private:
  std::uint64_t seed_;
  double dt_, white_, bias_step_;
  bool noisy_;
  Eigen::Vector3d gravity_, bias_ = Eigen::Vector3d::Zero(), velocity_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d rotation_ = Eigen::Matrix3d::Identity();
  DelayLine delay_;
  std::uint64_t tick_ = 0;
};

}  // namespace lab::realism
