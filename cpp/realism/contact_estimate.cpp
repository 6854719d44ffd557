// lab/realism/contact_estimate.py in C++ (same arithmetic, same order).
#include "realism/contact_estimate.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace lab::realism {

namespace {
constexpr double kGravity = 9.81;  // contact_estimate.py's G
}

ContactEstimator::ContactEstimator(const TouchThresholds& thresholds, double dt, int n_joints,
                                   int n_feet)
    : thresholds_(thresholds),
      dt_(dt),
      alpha_(thresholds.accel_filter_hz == 0.0
                 ? 1.0
                 : 1.0 - std::exp(-2.0 * M_PI * thresholds.accel_filter_hz * dt)),
      velocity_(Eigen::VectorXd::Zero(n_joints)),
      accelerations_(Eigen::VectorXd::Zero(n_joints)),
      normal_(Eigen::VectorXd::Zero(n_feet)),
      touch_(static_cast<std::size_t>(n_feet), 1) {  // a robot starts standing
  if (!(dt > 0.0)) throw std::invalid_argument("ContactEstimator: dt must be > 0 s");
  if (!(0.0 <= thresholds.off && thresholds.off <= thresholds.on) || thresholds.min_force < 0.0 ||
      thresholds.accel_filter_hz < 0.0)
    throw std::invalid_argument(
        "ContactEstimator: needs 0 <= off <= on, min_force >= 0 and accel_filter_hz >= 0");
}

void ContactEstimator::take_state(const Eigen::VectorXd* velocity,
                                  const Eigen::VectorXd& accelerations,
                                  const std::vector<char>& touch) {
  if (accelerations.size() != accelerations_.size() || touch.size() != touch_.size() ||
      (velocity != nullptr && velocity->size() != velocity_.size()))
    throw std::invalid_argument(
        "ContactEstimator.take_state: one velocity and acceleration per joint, one flag per "
        "foot");
  started_ = velocity != nullptr;
  if (started_) velocity_ = *velocity;
  accelerations_ = accelerations;
  touch_ = touch;
}

const std::vector<char>& ContactEstimator::update(const RobotModel& model,
                                                  const Eigen::Ref<const Eigen::VectorXd>& applied,
                                                  const Eigen::Ref<const Eigen::VectorXd>& vj,
                                                  const char* flags) {
  if (started_) accelerations_ += alpha_ * ((vj - velocity_) / dt_ - accelerations_);
  velocity_ = vj;
  started_ = true;
  const double share = model.mass * kGravity / static_cast<double>(model.contacts.size());
  const double on = std::max(thresholds_.on * share, thresholds_.min_force);
  const double off = thresholds_.off * share;
  for (std::size_t i = 0; i < model.contacts.size(); ++i) {
    const auto foot = static_cast<Eigen::Index>(i);
    // the leg's joints: the nonzero columns of the foot's contact Jacobian (exactly three)
    const int row = model.force_starts[i];
    int joints[3], n = 0;
    if (model.contacts[i].kind == ContactKind::point) {
      for (int j = 0; j < model.na && n <= 3; ++j) {
        if (model.Jc.block(row, BASE_DOF + j, 3, 1).isZero(0.0)) continue;
        if (n < 3) joints[n] = j;
        ++n;
      }
    }
    if (n != 3) {  // not estimable: the simulator's flag
      normal_(foot) = std::numeric_limits<double>::quiet_NaN();
      touch_[i] = flags[i];
      continue;
    }
    // F = J_c^-T (h_c - tau_c + M_c qdd_c), its normal (z) component
    Eigen::Matrix3d leg_t, mass;
    Eigen::Vector3d residual, qdd;
    for (int a = 0; a < 3; ++a) {
      const int da = BASE_DOF + joints[a];
      residual(a) = model.h(da) - applied(joints[a]);
      qdd(a) = accelerations_(joints[a]);
      for (int b = 0; b < 3; ++b) {
        leg_t(a, b) = model.Jc(row + b, da);
        mass(a, b) = model.M(da, BASE_DOF + joints[b]);
      }
    }
    residual += mass * qdd;
    const double normal = leg_t.partialPivLu().solve(residual)(2);
    normal_(foot) = normal;
    touch_[i] = touch_[i] ? normal > off : normal > on;
  }
  return touch_;
}

}  // namespace lab::realism
