// Centre-of-mass tasks (lab/controller/tasks/com.py): com and its horizontal rows com_xy.
#include "tasks/base.hpp"

namespace lab {
namespace {

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

/// The horizontal CoM alone (Table 6, P3): the first two rows of `com`.
class ComXYTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    com_.gains = gains;
    com_.compute(robot, refs);
    A = com_.A.topRows<2>();
    b = com_.b.head<2>();
    error = com_.error.head<2>();
  }

 private:
  ComTask com_;
};

}  // namespace

void add_com_tasks(TaskRegistry& tasks) {
  tasks["com"] = std::make_unique<ComTask>();
  tasks["com_xy"] = std::make_unique<ComXYTask>();
}

}  // namespace lab
