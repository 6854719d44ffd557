// lab/realism/contact_estimate.py in C++: the contact forces estimated from the applied torques
// (Raiola eq. 18 with the leg's acceleration) and the haptic touch detector on them, on the
// kernel's model at the measured state (see there for the model and the thresholds).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "model.hpp"

namespace lab::realism {

/// contact_estimate.py's TouchThresholds: on and off (fractions of a foot's weight share),
/// min_force (N), accel_filter_hz (Hz; 0: unfiltered differences).
struct TouchThresholds {
  double on = 0.5, off = 0.25, min_force = 10.0, accel_filter_hz = 100.0;
};

/// contact_estimate.py's ContactEstimator: the last measured joint velocities, the filtered
/// joint accelerations and each foot's touch state.
class ContactEstimator {
 public:
  ContactEstimator(const TouchThresholds& thresholds, double dt, int n_joints, int n_feet);
  /// This tick's touch flags from last tick's `applied` torques (N m) and the measured joint
  /// velocities `vj` (rad/s) at `model`'s state; a foot it cannot estimate keeps `flags[i]`.
  const std::vector<char>& update(const RobotModel& model,
                                  const Eigen::Ref<const Eigen::VectorXd>& applied,
                                  const Eigen::Ref<const Eigen::VectorXd>& vj, const char* flags);
  /// Continue from another estimator's state (the Python one's, on a switch of tick path):
  /// the last joint velocities (null: not started), filtered accelerations and touch flags.
  void take_state(const Eigen::VectorXd* velocity, const Eigen::VectorXd& accelerations,
                  const std::vector<char>& touch);
  const Eigen::VectorXd& normal() const { return normal_; }
  const Eigen::VectorXd& accelerations() const { return accelerations_; }
  const std::vector<char>& touch() const { return touch_; }
  bool started() const { return started_; }
  const Eigen::VectorXd& velocity() const { return velocity_; }
  int n_joints() const { return static_cast<int>(velocity_.size()); }
  int n_feet() const { return static_cast<int>(touch_.size()); }

 private:
  TouchThresholds thresholds_;
  double dt_, alpha_;
  bool started_ = false;  // whether velocity_ holds a measurement
  Eigen::VectorXd velocity_, accelerations_, normal_;
  std::vector<char> touch_;  // bools: std::vector<bool> has no data()
};

}  // namespace lab::realism
