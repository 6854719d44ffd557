// Posture tasks (lab/controller/tasks/posture.py): posture (Raiola eq. 9), moving_posture and
// upper_body.
#include "tasks/posture.hpp"

#include "tasks/feet.hpp"

namespace lab {

std::vector<std::vector<Eigen::Index>> leg_joints(const RobotModel& robot) {
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

namespace {

/// Joint accelerations q̈_j = kp (q_ref − q_j) − kd q̇_j (Raiola eq. 9).
class PostureTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    reset(robot, robot.na);
    A.block(0, BASE_DOF, robot.na, robot.na).setIdentity();
    error = refs.posture - robot.q.tail(robot.na);
    b = gains.kp * error - gains.kd * robot.v.tail(robot.na);
  }
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
  std::vector<std::vector<Eigen::Index>> legs_;
  Eigen::VectorXd weight_;  // of each actuated joint this tick
};

/// Raiola eq. 9 on the joints that move no contact (torso or waist and arms),
/// q̈_j = kp (q_ref − q_j) − kd q̇_j; the error is q_ref − q_j of those joints (rad).
class UpperBodyTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    if (!found_) {  // at the first tick, as the Python task
      std::vector<bool> in_leg(static_cast<std::size_t>(robot.na), false);
      for (const auto& leg : leg_joints(robot))
        for (Eigen::Index j : leg) in_leg[static_cast<std::size_t>(j)] = true;
      for (Eigen::Index j = 0; j < robot.na; ++j)
        if (!in_leg[static_cast<std::size_t>(j)]) joints_.push_back(j);
      found_ = true;
    }
    const auto n = static_cast<Eigen::Index>(joints_.size());
    reset(robot, n);
    error.resize(n);
    for (Eigen::Index row = 0; row < n; ++row) {
      const Eigen::Index j = joints_[static_cast<std::size_t>(row)];
      A(row, BASE_DOF + j) = 1.0;
      error[row] = refs.posture[j] - robot.q[7 + j];
      b[row] = gains.kp * error[row] - gains.kd * robot.v[BASE_DOF + j];
    }
  }

 private:
  bool found_ = false;
  std::vector<Eigen::Index> joints_;  // the actuated joints in no leg
};

}  // namespace

void add_posture_tasks(TaskRegistry& tasks) {
  tasks["posture"] = std::make_unique<PostureTask>();
  tasks["moving_posture"] = std::make_unique<MovingPostureTask>();
  tasks["upper_body"] = std::make_unique<UpperBodyTask>();
}

}  // namespace lab
