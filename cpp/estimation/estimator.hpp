// lab/world/estimator.py's BaseEstimator under `estimator = "ekf"`, in C++: the accelerometer
// (realism/accelerometer.hpp) and the EKF (filter.hpp) turn the true state and the realism
// layer's measured one into the state the controller reads. The native tick calls `read` between
// the layer's measurement and the model update (plant/server_tick.cpp); a Python tick calls it
// through the binding (estimation/python.cpp), so the filter's state lives here alone.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "estimation/filter.hpp"
#include "realism/accelerometer.hpp"

namespace lab::estimation {

class BaseEstimator {
 public:
  BaseEstimator(LeggedEkf filter, realism::Accelerometer accelerometer)
      : filter_(std::move(filter)), accelerometer_(std::move(accelerometer)) {}
  /// A new run from the true state (q, v): the filter starts there.
  void reset(const Eigen::Ref<const Eigen::VectorXd>& q,
             const Eigen::Ref<const Eigen::VectorXd>& v);
  /// The state the controller reads this tick, written over the measured (qm, vm): the base
  /// estimated from the true (q, v)'s accelerometer, the measured gyroscope and joints, and the
  /// feet in `contacts` (the controller's); kept as `estimate`.
  void read(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& v,
            Eigen::Ref<Eigen::VectorXd> qm, Eigen::Ref<Eigen::VectorXd> vm, const Flags& contacts);
  const LeggedEkf& filter() const { return filter_; }

 private:
  LeggedEkf filter_;
  realism::Accelerometer accelerometer_;
};

}  // namespace lab::estimation
