// Trunk tasks (lab/controller/tasks/trunk.py): base_orientation, base_height, and Hutter 2014
// Table 7's roll_pitch, yaw_rate, base_velocity.
#include <pinocchio/spatial/explog.hpp>

#include "tasks/base.hpp"

namespace lab {
namespace {

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
  tasks["base_orientation"] = std::make_unique<BaseOrientationTask>();
  tasks["base_height"] = std::make_unique<BaseHeightTask>();
  tasks["roll_pitch"] = std::make_unique<RollPitchTask>();
  tasks["yaw_rate"] = std::make_unique<YawRateTask>();
  tasks["base_velocity"] = std::make_unique<PlanarVelocityTask>();
}

}  // namespace lab
