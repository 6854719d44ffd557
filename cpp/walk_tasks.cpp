// Motion tasks of the static-walk experiments (lab/controller/walk_tasks.py, Hutter 2014 §5.1):
// swing_feet, com_xy, moving_posture.
#include "tasks_common.hpp"

namespace lab {
namespace {

/// Flags of the point feet out of contact.
Eigen::Array<bool, Eigen::Dynamic, 1> swinging(
    const RobotModel& robot, const Eigen::Array<bool, Eigen::Dynamic, 1>& active) {
  Eigen::Array<bool, Eigen::Dynamic, 1> out(active.size());
  for (Eigen::Index i = 0; i < active.size(); ++i)
    out[i] = robot.contacts[i].kind == ContactKind::point && !active[i];
  return out;
}

/// Whether the references give the feet swing trajectories (walking references do).
bool has_swing(const References& refs) { return refs.foot_position.size() > 0; }

/// Each point foot out of support tracks its swing trajectory, world axes:
/// J_i q̈ + J̇_i v = a_ref + kp (p_ref − p) + kd (v_ref − v).
class SwingFeetTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    Eigen::Index n = 0;
    if (has_swing(refs)) {
      feet_ = swinging(robot, refs.contact_active);
      contact_rows(robot, feet_, index_);
      n = static_cast<Eigen::Index>(index_.size());
    }
    const auto& index = index_;
    const auto& feet = feet_;
    reset(robot, n);
    error.resize(n);
    if (n == 0) return;
    write_jacobian_rows(robot, index, A);
    velocity_.noalias() = A.leftCols(robot.nv) * robot.v;
    const Eigen::VectorXd& velocity = velocity_;
    Eigen::Index row = 0;
    for (Eigen::Index i = 0; i < feet.size(); ++i) {
      if (!feet[i]) continue;
      for (int k = 0; k < 3; ++k, ++row) {
        const Eigen::Index c = 3 * i + k;
        const double e = refs.foot_position[c] - robot.contact_positions[i][k];
        const double de = refs.foot_velocity[c] - velocity[row];
        error[row] = e;
        b[row] =
            refs.foot_acceleration[c] + gains.kp * e + gains.kd * de - robot.Jc_dot_v[index[row]];
      }
    }
  }

 private:
  Eigen::Array<bool, Eigen::Dynamic, 1> feet_;  // swinging point feet
  std::vector<Eigen::Index> index_;             // their rows of Jc
  Eigen::VectorXd velocity_;                    // their velocities J v
};

/// The horizontal CoM alone (Table 6, P3): the first two rows of `com`.
class ComXYTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    com_->gains = gains;
    com_->compute(robot, refs);
    A = com_->A.topRows<2>();
    b = com_->b.head<2>();
    error = com_->error.head<2>();
  }

 private:
  std::unique_ptr<Task> com_ = make_com_task();
};

/// Raiola's postural task eq. 9 with a moving reference, each leg's rows weighted by its load
/// ramp, a swinging leg's joints left out (q̈_a = kp (q_d − q_a) + kd (q̇_d − q̇_a)).
class MovingPostureTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    if (legs_.empty()) legs_ = leg_joints(robot);  // at the first tick, as the Python task
    const auto n_legs = static_cast<Eigen::Index>(legs_.size());
    // Each joint's weight: the last leg that moves it, 0 on a swinging leg, 1 outside the legs.
    Eigen::VectorXd& weight = weight_;
    weight.setOnes(robot.na);
    const bool walk_weights = refs.posture_weight.size() == n_legs;
    for (Eigen::Index i = 0; i < n_legs; ++i)
      for (Eigen::Index j : legs_[i]) weight[j] = walk_weights ? refs.posture_weight[i] : 1.0;
    if (has_swing(refs)) {
      const auto feet = swinging(robot, refs.contact_active);
      for (Eigen::Index i = 0; i < n_legs; ++i)
        if (feet[i])
          for (Eigen::Index j : legs_[i]) weight[j] = 0.0;
    }
    const bool moving = refs.posture_velocity.size() == robot.na;
    reset(robot, (weight.array() > 0.0).count());
    error.resize(A.rows());
    Eigen::Index row = 0;
    for (Eigen::Index j = 0; j < robot.na; ++j) {
      if (!(weight[j] > 0.0)) continue;
      const double w = weight[j];
      const double e = refs.posture[j] - robot.q[7 + j];
      const double de = (moving ? refs.posture_velocity[j] : 0.0) - robot.v[BASE_DOF + j];
      A(row, BASE_DOF + j) = w;
      error[row] = e;
      b[row] = w * (gains.kp * e + gains.kd * de);
      ++row;
    }
  }

 private:
  /// Actuated-joint indices of each contact's leg: the joints that move the contact point.
  static std::vector<std::vector<Eigen::Index>> leg_joints(const RobotModel& robot) {
    std::vector<std::vector<Eigen::Index>> legs;
    for (std::size_t i = 0; i < robot.contacts.size(); ++i) {
      const auto rows = robot.Jc.middleRows(robot.force_starts[i], robot.contacts[i].force_dim());
      std::vector<Eigen::Index> leg;
      for (Eigen::Index j = 0; j < robot.na; ++j)
        if ((rows.col(BASE_DOF + j).array().abs() > 1e-9).any()) leg.push_back(j);
      legs.push_back(std::move(leg));
    }
    return legs;
  }

  std::vector<std::vector<Eigen::Index>> legs_;
  Eigen::VectorXd weight_;  // of each actuated joint this tick
};

}  // namespace

void add_walk_tasks(TaskRegistry& tasks) {
  tasks["swing_feet"] = std::make_unique<SwingFeetTask>();
  tasks["com_xy"] = std::make_unique<ComXYTask>();
  tasks["moving_posture"] = std::make_unique<MovingPostureTask>();
}

}  // namespace lab
