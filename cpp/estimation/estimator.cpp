// lab/world/estimator.py's BaseEstimator.read in C++ (same order: the accelerometer, the step,
// the estimate).
#include "estimation/estimator.hpp"

namespace lab::estimation {

namespace {
constexpr int kBaseQ = 7, kBaseV = 6;  // free-flyer coordinates of q and v
}

void BaseEstimator::reset(const Eigen::Ref<const Eigen::VectorXd>& q,
                          const Eigen::Ref<const Eigen::VectorXd>& v) {
  accelerometer_.reset(q, v);
  filter_.reset(q, v);
}

void BaseEstimator::read(const Eigen::Ref<const Eigen::VectorXd>& q,
                         const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Ref<Eigen::VectorXd> qm,
                         Eigen::Ref<Eigen::VectorXd> vm, const Flags& contacts) {
  const Eigen::Vector3d gyro = vm.segment<3>(3);  // the layer's gyroscope: ω + bias + noise
  const Eigen::Vector3d accel = accelerometer_.measure(q, v);
  filter_.step(accel, gyro, qm.tail(qm.size() - kBaseQ), vm.tail(vm.size() - kBaseV), contacts);
  filter_.configuration(qm);
  filter_.velocity(gyro, vm);
}

}  // namespace lab::estimation
