// lab/realism/sensors.py in C++ (Kalibr's discrete noise: white σ/√dt, random walk σ√dt).
#include "realism/sensors.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <pinocchio/spatial.hpp>  // exp3

namespace lab::realism {

Imu::Imu(const Knobs& knobs, double dt)
    : attitude_(knobs.attitude_noise),
      gyro_(knobs.gyro_noise / std::sqrt(dt)),
      bias_step_(knobs.gyro_bias_walk * std::sqrt(dt)),
      velocity_(knobs.base_velocity_noise),
      position_(knobs.base_position_noise) {}

void Imu::measure(Eigen::Ref<Eigen::VectorXd> q, Eigen::Ref<Eigen::VectorXd> v,
                  const double* noise) {
  using Eigen::Map;
  using Eigen::Vector3d;
  if (attitude_ > 0.0) {  // R_meas = R exp(δθ), δθ in the base frame
    const Eigen::Quaterniond base(q[6], q[3], q[4], q[5]);
    const Vector3d turn = attitude_ * Map<const Vector3d>(noise);
    Eigen::Quaterniond turned(Eigen::Matrix3d(base.toRotationMatrix() * pinocchio::exp3(turn)));
    turned.normalize();
    q.segment<4>(3) = turned.coeffs();  // x, y, z, w as pinocchio's q
  }
  bias_ += bias_step_ * Map<const Vector3d>(noise + 6);
  v.segment<3>(3) += bias_ + gyro_ * Map<const Vector3d>(noise + 3);
  v.segment<3>(0) += velocity_ * Map<const Vector3d>(noise + 9);
  q.segment<3>(0) += position_ * Map<const Vector3d>(noise + 12);
}

Encoders::Encoders(const Knobs& knobs, int na, double dt)
    : noise_(knobs.encoder_noise),
      resolution_(knobs.encoder_bits ? 2.0 * M_PI / std::ldexp(1.0, knobs.encoder_bits) : 0.0),
      alpha_(knobs.velocity_filter_hz > 0.0
                 ? 1.0 - std::exp(-2.0 * M_PI * knobs.velocity_filter_hz * dt)
                 : 1.0),
      dt_(dt),
      differencing_(knobs.velocity_differencing),
      previous_(Eigen::VectorXd::Zero(na)),
      velocity_(Eigen::VectorXd::Zero(na)) {}

void Encoders::measure(Eigen::Ref<Eigen::VectorXd> qj, Eigen::Ref<Eigen::VectorXd> vj,
                       const double* noise) {
  const Eigen::Index na = qj.size();
  for (Eigen::Index i = 0; i < na; ++i) {
    double angle = qj[i] + noise_ * noise[i];
    if (resolution_ > 0.0) angle = std::nearbyint(angle / resolution_) * resolution_;
    qj[i] = angle;
  }
  if (!differencing_) return;
  if (started_) velocity_ += alpha_ * ((qj - previous_) / dt_ - velocity_);
  previous_ = qj;
  started_ = true;
  vj = velocity_;
}

}  // namespace lab::realism
