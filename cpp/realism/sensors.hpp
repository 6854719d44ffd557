// lab/realism/sensors.py in C++: the IMU and the encoders (see there for the models).
#pragma once

#include <Eigen/Core>

#include "realism/knobs.hpp"

namespace lab::realism {

constexpr int kImuDraws = 15;  // attitude 3, gyro white 3, gyro bias walk 3, velocity 3, position 3

/// The base part of the measured state (pinocchio conventions: v in the base frame).
class Imu {
 public:
  Imu(const Knobs& knobs, double dt);
  void reset() { bias_.setZero(); }
  /// Corrupt the base entries of (q, v) in place with kImuDraws normals `noise`.
  void measure(Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> v, const double* noise);

 private:
  double attitude_, gyro_, bias_step_, velocity_, position_;
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
};

/// The joint part: quantized noisy angles, true or differenced and low-passed velocities.
class Encoders {
 public:
  Encoders(const Knobs& knobs, int na, double dt);
  void reset() {
    velocity_.setZero();
    started_ = false;
  }
  /// Corrupt joint angles `qj` and velocities `vj` in place with na normals `noise`.
  void measure(Eigen::Ref<Eigen::VectorXd> qj, Eigen::Ref<Eigen::VectorXd> vj, const double* noise);

 private:
  double noise_, resolution_, alpha_, dt_;
  bool differencing_, started_ = false;
  Eigen::VectorXd previous_, velocity_;
};

}  // namespace lab::realism
