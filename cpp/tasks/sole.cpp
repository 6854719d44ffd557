// The swing-sole tasks of Herzog 2016 Table 4 and §5.4 (lab/controller/tasks/sole.py):
// swing_sole (a flat foot out of support holds a pose) and swing_leg (its leg's joints track a
// trajectory while it swings). References without sole targets give no rows.
#include <pinocchio/spatial/explog.hpp>

#include "tasks/posture.hpp"

namespace lab {
namespace {

using Flags = Eigen::Array<bool, Eigen::Dynamic, 1>;

/// Whether the references mark legs swinging in joint space (sole.py leg_swinging), and which:
/// those marked and out of support.
bool legs_swinging(const References& refs, Flags& out) {
  if (refs.leg_swinging.size() == 0) return false;
  out = refs.leg_swinging && !refs.contact_active;
  return true;
}

/// Flat feet out of support (and whose leg does not swing) track their sole pose with the
/// Cartesian PD of §5.4 in the sole frame: J q̈ + J̇ v = [Rᵀ kp (p_ref − p) − kd v;
/// kp log₃(Rᵀ R_ref) − kd ω]; the error is [p_ref − p (world); log₃(Rᵀ R_ref)] per foot.
class SwingSoleTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    Eigen::Index n = 0;
    if (refs.sole_position.size() > 0) {
      held_ = refs.contact_active;  // feet in support, or whose leg swings in joint space
      if (legs_swinging(refs, swinging_)) held_ = held_ || swinging_;
      feet_.resize(held_.size());
      for (Eigen::Index i = 0; i < held_.size(); ++i)
        feet_[i] = robot.contacts[i].kind == ContactKind::flat && !held_[i];
      contact_rows(robot, feet_, index_);
      n = static_cast<Eigen::Index>(index_.size());
    }
    reset(robot, n);
    error.resize(n);
    if (n == 0) return;
    write_jacobian_rows(robot, index_, A);
    velocity_.noalias() = A.leftCols(robot.nv) * robot.v;
    Eigen::Index row = 0;
    for (Eigen::Index i = 0; i < feet_.size(); ++i) {
      if (!feet_[i]) continue;
      const Eigen::Matrix3d& R = robot.contact_rotations[i];
      const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> target(
          refs.sole_rotation.data() + 9 * i);
      error.segment<3>(row) = refs.sole_position.segment<3>(3 * i) - robot.contact_positions[i];
      error.segment<3>(row + 3) = pinocchio::log3(Eigen::Matrix3d(R.transpose() * target));
      Eigen::Matrix<double, 6, 1> local;  // the error in the sole frame, as J's rows
      local << R.transpose() * error.segment<3>(row), error.segment<3>(row + 3);
      for (int k = 0; k < 6; ++k)
        b[row + k] =
            -robot.Jc_dot_v[index_[row + k]] + gains.kp * local[k] - gains.kd * velocity_[row + k];
      row += 6;
    }
  }

 private:
  Flags held_, swinging_, feet_;     // feet_: the flat feet with rows
  std::vector<Eigen::Index> index_;  // their rows of Jc
  Eigen::VectorXd velocity_;         // their velocities J v
};

/// The joints of each leg the references mark swinging track their trajectory,
/// q̈ = q̈_ref + kp (q_ref − q) + kd (q̇_ref − q̇); the error is q_ref − q (rad).
class SwingLegTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    if (!legs_swinging(refs, swinging_) || !swinging_.any()) {
      reset(robot, 0);
      error.resize(0);
      return;
    }
    if (legs_.empty()) legs_ = leg_joints(robot);  // at the first swing, as the Python task
    joints_.clear();
    for (Eigen::Index i = 0; i < swinging_.size(); ++i)
      if (swinging_[i]) joints_.insert(joints_.end(), legs_[i].begin(), legs_[i].end());
    const auto n = static_cast<Eigen::Index>(joints_.size());
    reset(robot, n);
    error.resize(n);
    for (Eigen::Index row = 0; row < n; ++row) {
      const Eigen::Index j = joints_[row];
      const double e = refs.leg_position[j] - robot.q[7 + j];
      const double de = refs.leg_velocity[j] - robot.v[BASE_DOF + j];
      A(row, BASE_DOF + j) = 1.0;
      error[row] = e;
      b[row] = refs.leg_acceleration[j] + gains.kp * e + gains.kd * de;
    }
  }

 private:
  std::vector<std::vector<Eigen::Index>> legs_;
  Flags swinging_;
  std::vector<Eigen::Index> joints_;  // of the swinging legs, leg by leg
};

}  // namespace

void add_sole_tasks(TaskRegistry& tasks) {
  tasks["swing_sole"] = std::make_unique<SwingSoleTask>();
  tasks["swing_leg"] = std::make_unique<SwingLegTask>();
}

}  // namespace lab
