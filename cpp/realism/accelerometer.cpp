// lab/realism/accelerometer.py in C++ (same draws, same arithmetic).
#include "realism/accelerometer.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "realism/rng.hpp"

namespace lab::realism {
namespace {

/// The base's rotation (base → world) of configuration `q` (quaternion x, y, z, w).
Eigen::Matrix3d base_rotation(const Eigen::Ref<const Eigen::VectorXd>& q) {
  return Eigen::Quaterniond(q[6], q[3], q[4], q[5]).toRotationMatrix();
}

}  // namespace

Accelerometer::Accelerometer(double noise, double bias_walk, int delay, std::uint64_t seed,
                             double dt, const Eigen::Vector3d& gravity)
    : seed_(seed),
      dt_(dt),
      white_(noise / std::sqrt(dt)),
      bias_step_(bias_walk * std::sqrt(dt)),
      noisy_(white_ > 0.0 || bias_step_ > 0.0),
      gravity_(gravity),
      delay_(delay, 3) {}

void Accelerometer::reset(const Eigen::Ref<const Eigen::VectorXd>& q,
                          const Eigen::Ref<const Eigen::VectorXd>& v) {
  rotation_ = base_rotation(q);
  velocity_ = rotation_ * v.head<3>();
  bias_.setZero();
  delay_.reset();
  tick_ = 0;
}

Eigen::Vector3d Accelerometer::measure(const Eigen::Ref<const Eigen::VectorXd>& q,
                                       const Eigen::Ref<const Eigen::VectorXd>& v) {
  const Eigen::Matrix3d rotation = base_rotation(q);
  const Eigen::Vector3d velocity = rotation * v.head<3>();
  Eigen::Vector3d force = rotation_.transpose() * ((velocity - velocity_) / dt_ - gravity_);
  rotation_ = rotation;
  velocity_ = velocity;
  if (noisy_) {
    const std::uint64_t first = tick_ * kAccelDraws;
    double noise[kAccelDraws];
    for (int i = 0; i < kAccelDraws; ++i) noise[i] = normal(seed_ ^ kAccelStream, first + i);
    for (int k = 0; k < 3; ++k) {
      bias_[k] += bias_step_ * noise[3 + k];
      force[k] += bias_[k] + white_ * noise[k];
    }
  }
  ++tick_;
  return delay_.push(force);
}

}  // namespace lab::realism
