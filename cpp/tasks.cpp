// Motion and force tasks of lab/controller/tasks.py: contact, base_orientation, com,
// base_height, posture, forces. PD law a_des = a_ref + kp e + kd ė (Raiola eqs. 7–9).
#include "tasks.hpp"

#include <pinocchio/spatial/explog.hpp>

#include "tasks_common.hpp"

namespace lab {

void Task::reset(const RobotModel& robot, Eigen::Index n) {
  A.setZero(n, robot.nx);  // no allocation while n stays the same
  b.setZero(n);
}

void Constraint::reset(const RobotModel& robot, Eigen::Index n) {
  C.setZero(n, robot.nx);
  d.setZero(n);
}

void contact_rows(const RobotModel& robot, const Eigen::Array<bool, Eigen::Dynamic, 1>& flags,
                  std::vector<Eigen::Index>& rows) {
  rows.clear();
  for (std::size_t i = 0; i < robot.contacts.size(); ++i)
    if (flags[i])
      for (int k = 0; k < robot.contacts[i].force_dim(); ++k)
        rows.push_back(robot.force_starts[i] + k);
}

void write_jacobian_rows(const RobotModel& robot, const std::vector<Eigen::Index>& index,
                         Eigen::MatrixXd& A) {
  for (std::size_t r = 0; r < index.size(); ++r) A.row(r).head(robot.nv) = robot.Jc.row(index[r]);
}

namespace {

/// Feet in contact do not accelerate: J_c q̈ = −J̇_c v − kd J_c v (Raiola eq. 7).
class ContactTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    contact_rows(robot, refs.contact_active, index_);
    const auto n = static_cast<Eigen::Index>(index_.size());
    reset(robot, n);
    write_jacobian_rows(robot, index_, A);
    error.noalias() = A.leftCols(robot.nv) * robot.v;
    for (Eigen::Index r = 0; r < n; ++r) b[r] = -robot.Jc_dot_v[index_[r]];
    if (gains.kd != 0.0) b -= gains.kd * error;
  }

 private:
  std::vector<Eigen::Index> index_;
};

/// Base angular acceleration in world axes tracks ω̇ = kp log(R_ref Rᵀ) + kd (ω_ref − ω).
class BaseOrientationTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const Eigen::Matrix3d& R = robot.base_rotation;
    const Eigen::Vector3d e = pinocchio::log3((refs.base_rotation * R.transpose()).eval());
    const Eigen::Vector3d de = refs.base_angular_velocity - R * robot.v.segment<3>(3);
    reset(robot, 3);
    A.block<3, 3>(0, 3) = R;
    error = e;
    b = gains.kp * e + gains.kd * de;
  }
};

/// CoM acceleration J_com q̈ + J̇_com v = kp (c_ref − c) + kd (ċ_ref − ċ).
class ComTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const Eigen::Vector3d e = refs.com - robot.com;
    const Eigen::Vector3d de = refs.com_velocity - robot.com_velocity;
    reset(robot, 3);
    A.leftCols(robot.nv) = robot.Jcom;
    error = e;
    b = gains.kp * e + gains.kd * de - robot.com_drift;
  }
};

/// Vertical base acceleration: z row of d/dt(R v_b) = R (v̇_b + ω_b × v_b).
class BaseHeightTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const Eigen::Matrix3d& R = robot.base_rotation;
    const Eigen::Vector3d v_lin = robot.v.head<3>(), w = robot.v.segment<3>(3);
    const double e = refs.base_height - robot.q[2];
    const double de = -(R * v_lin)[2];
    reset(robot, 1);
    A.block<1, 3>(0, 0) = R.row(2);
    const double drift = (R * w.cross(v_lin))[2];
    error.setConstant(1, e);
    b[0] = gains.kp * e + gains.kd * de - drift;
  }
};

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

/// Contact-force regularization: F → 0.
class ForceTask : public Task {
 public:
  void compute(const RobotModel& robot, const References&) override {
    reset(robot, robot.nf);
    A.rightCols(robot.nf).setIdentity();
  }
};

}  // namespace

std::unique_ptr<Task> make_com_task() { return std::make_unique<ComTask>(); }

void add_tasks(TaskRegistry& tasks) {
  tasks["contact"] = std::make_unique<ContactTask>();
  tasks["base_orientation"] = std::make_unique<BaseOrientationTask>();
  tasks["com"] = make_com_task();
  tasks["base_height"] = std::make_unique<BaseHeightTask>();
  tasks["posture"] = std::make_unique<PostureTask>();
  tasks["forces"] = std::make_unique<ForceTask>();
}

TaskRegistry make_tasks() {
  TaskRegistry tasks;
  add_tasks(tasks);
  add_trunk_tasks(tasks);
  add_objectives(tasks);
  add_walk_tasks(tasks);
  return tasks;
}

}  // namespace lab
