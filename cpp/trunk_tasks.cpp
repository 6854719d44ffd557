// Trunk tasks of Hutter's dynamic-trot hierarchy (lab/controller/trunk_tasks.py, Hutter 2014
// Table 7): roll_pitch, yaw_rate, base_velocity.
#include <pinocchio/spatial/explog.hpp>

#include "tasks.hpp"

namespace lab {
namespace {

/// Base-frame x, y rows of the angular acceleration: ω̇_b,xy = kp e_b,xy + kd (ω_ref − ω)_b,xy.
class RollPitchTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const Eigen::Matrix3d& R = robot.base_rotation;
    const Eigen::Vector3d e =
        R.transpose() * pinocchio::log3((refs.base_rotation * R.transpose()).eval());
    const Eigen::Vector3d de = R.transpose() * refs.base_angular_velocity - robot.v.segment<3>(3);
    reset(robot, 2);
    A(0, 3) = A(1, 4) = 1.0;
    error = e.head<2>();
    b = gains.kp * e.head<2>() + gains.kd * de.head<2>();
  }
};

/// Turning rate about the world vertical (Table 7 P4): ω̇_z = kd (ψ̇_ref − ψ̇).
class YawRateTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const Eigen::Matrix3d& R = robot.base_rotation;
    const double e = refs.base_angular_velocity[2] - R.row(2).dot(robot.v.segment<3>(3));
    reset(robot, 1);
    A.block<1, 3>(0, 3) = R.row(2);
    error.setConstant(1, e);
    b[0] = gains.kd * e;
  }
};

/// Body velocity along the base x and y axes (Table 7 P5): v̇_b,xy = kd (v_ref − v)_b,xy.
class PlanarVelocityTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const Eigen::Vector3d e =
        robot.base_rotation.transpose() * refs.base_linear_velocity - robot.v.head<3>();
    reset(robot, 2);
    A(0, 0) = A(1, 1) = 1.0;
    error = e.head<2>();
    b = gains.kd * e.head<2>();
  }
};

}  // namespace

void add_trunk_tasks(TaskRegistry& tasks) {
  tasks["roll_pitch"] = std::make_unique<RollPitchTask>();
  tasks["yaw_rate"] = std::make_unique<YawRateTask>();
  tasks["base_velocity"] = std::make_unique<PlanarVelocityTask>();
}

}  // namespace lab
