// What the behaviour asks of the tasks this tick (mirrors lab/controller/references.py,
// walk_references.py and tasks/sole.py's SoleReferences). The behaviour owns them in Python;
// Kernel.set_references copies them in. A walking field left empty means what the Python side does
// for a plain References: flat ground, no swing trajectories, no force interpolation, zero posture
// velocity, full postural weight.
#pragma once

#include <Eigen/Dense>

namespace lab {

struct References {
  Eigen::Vector3d com = Eigen::Vector3d::Zero();
  Eigen::VectorXd posture;  // actuated joint positions, pinocchio order
  double base_height = 0.0;
  Eigen::Matrix3d base_rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d com_velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d com_acceleration = Eigen::Vector3d::Zero();  // fed forward by momentum (eq. 22)
  Eigen::Vector3d base_angular_velocity = Eigen::Vector3d::Zero();  // world axes
  Eigen::Array<bool, Eigen::Dynamic, 1> contact_active;
  Eigen::VectorXd normal_force_max;  // per contact (N); empty: the robot-wide bound
  Eigen::Vector3d base_linear_velocity = Eigen::Vector3d::Zero();  // world axes

  // WalkReferences: per-contact rows (n_contacts, 3) stored row-major flat, or empty.
  Eigen::VectorXd foot_position;
  Eigen::VectorXd foot_velocity;
  Eigen::VectorXd foot_acceleration;
  Eigen::VectorXd surface_normal;
  Eigen::VectorXd force_weight;      // per contact; NaN: not changing
  Eigen::VectorXd posture_velocity;  // per actuated joint
  Eigen::VectorXd posture_weight;    // per contact's leg

  // SoleReferences (tasks/sole.py), or empty: each sole's pose target (world position (n, 3) and
  // rotation (n, 3, 3), row-major flat), the legs swinging in joint space and their trajectory
  // (actuated joints, pinocchio order).
  Eigen::VectorXd sole_position;
  Eigen::VectorXd sole_rotation;
  Eigen::Array<bool, Eigen::Dynamic, 1> leg_swinging;
  Eigen::VectorXd leg_position;
  Eigen::VectorXd leg_velocity;
  Eigen::VectorXd leg_acceleration;
};

}  // namespace lab
