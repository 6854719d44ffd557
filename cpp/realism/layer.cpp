// lab/realism/layer.py in C++ (same order of operations and of draws).
#include "realism/layer.hpp"

#include <stdexcept>

#include "realism/rng.hpp"

namespace lab::realism {

namespace {
constexpr int kBaseQ = 7, kBaseV = 6;  // free-flyer coordinates of q and v
}

Layer::Layer(const Knobs& knobs, int na, double dt)
    : knobs_(knobs),
      na_(na),
      width_(kImuDraws + na),
      imu_(knobs, dt),
      encoders_(knobs, na, dt),
      state_delay_(knobs.measurement_delay, kBaseQ + na + kBaseV + na),
      command_delay_(knobs.command_delay, na),
      noise_(Eigen::VectorXd::Zero(kImuDraws + na)) {
  if (knobs.actuator == "bandwidth")
    bandwidth_ = std::make_unique<FirstOrderTorque>(knobs, na, dt);
  else if (knobs.actuator == "sea")
    sea_ = std::make_unique<SeriesElastic>(knobs, na, dt);
  else if (knobs.actuator != "ideal")
    throw std::invalid_argument("realism: actuator must be ideal, bandwidth or sea, not " +
                                knobs.actuator);
  noisy_ = knobs.gyro_noise > 0.0 || knobs.gyro_bias_walk > 0.0 || knobs.attitude_noise > 0.0 ||
           knobs.base_velocity_noise > 0.0 || knobs.base_position_noise > 0.0 ||
           knobs.encoder_noise > 0.0;
  ideal_ = !noisy_ && knobs.encoder_bits == 0 && !knobs.velocity_differencing &&
           knobs.measurement_delay == 0 && knobs.command_delay == 0 && !bandwidth_ && !sea_;
}

void Layer::reset(const Eigen::VectorXd& q, const Eigen::VectorXd& tau) {
  tick_ = 0;
  imu_.reset();
  encoders_.reset();
  state_delay_.reset();
  command_delay_.reset();
  if (sea_) sea_->reset(q.tail(na_), tau);
  if (bandwidth_) bandwidth_->reset(tau);
}

std::pair<Eigen::VectorXd, Eigen::VectorXd> Layer::measure(const Eigen::VectorXd& q,
                                                           const Eigen::VectorXd& v) {
  const Eigen::Index nq = q.size();
  Eigen::VectorXd both(nq + v.size());
  both << q, v;
  const Eigen::VectorXd delayed = state_delay_.push(both);
  Eigen::VectorXd qm = delayed.head(nq), vm = delayed.tail(v.size());
  if (noisy_) {
    const std::uint64_t first = tick_ * static_cast<std::uint64_t>(width_);
    for (int i = 0; i < width_; ++i) noise_[i] = normal(knobs_.seed, first + i);
  }
  ++tick_;
  imu_.measure(qm, vm, noise_.data());
  encoders_.measure(qm.tail(na_), vm.tail(na_), noise_.data() + kImuDraws);
  return {qm, vm};
}

Eigen::VectorXd Layer::actuate(const Eigen::VectorXd& command, const Eigen::VectorXd& q,
                               const Eigen::VectorXd& v) {
  const Eigen::VectorXd delayed = command_delay_.push(command);
  if (bandwidth_) return bandwidth_->apply(delayed);
  if (sea_) return sea_->apply(delayed, q.tail(na_), v.tail(na_));
  return delayed;
}

}  // namespace lab::realism
