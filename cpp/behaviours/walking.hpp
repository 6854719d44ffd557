// Walking: the walking pattern generator of Raiola §3 as a behaviour (trot, crawl); mirrors
// lab/controller/behaviours/walking.py (Walking.update, _swing_feet, _filter_twist), whose
// docstring explains each reference. The Python Walking keeps the state between ticks and the
// bindings (behaviours/python.cpp) load it into this struct and write it back; on a native tick
// one call runs the whole tick below, the leg posture (leg_posture.cpp) included.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "behaviours/behaviour.hpp"
#include "behaviours/footholds.hpp"
#include "behaviours/gait.hpp"
#include "behaviours/leg_posture.hpp"

namespace lab {

/// What the walking tick reads of the robot model: the arrays the native kernel's update fills
/// (RobotModel.arrays(); world axes, base velocities in the base frame as in v).
struct WalkingModel {
  Eigen::Map<const Eigen::VectorXd> q, v;
  Eigen::Map<const RowMatrix3> base_rotation;
  Eigen::Map<const RowMatrixX3> contact_positions;  // n x 3
  Eigen::Map<const RowMatrixX3> contact_rotations;  // 3n x 3
  Eigen::Map<const RowMatrixX> contact_jacobian;    // 3n x nv (point feet)
};

/// The references the walking tick writes (the WalkReferences' arrays, in place).
struct WalkingReferences {
  bool* contact_active;                                                     // n
  Eigen::Map<Eigen::VectorXd> posture_weight;                               // n
  Eigen::Map<Eigen::VectorXd> normal_force_max;                             // n
  Eigen::Map<RowMatrixX3> foot_position, foot_velocity, foot_acceleration;  // n x 3 each
  Eigen::Map<RowMatrix3> base_rotation;
  Eigen::Map<Eigen::Vector3d> base_angular_velocity, base_linear_velocity, com, com_velocity;
  double base_height;
};

/// The leg posture references' state (leg_posture.py LegPostureReference).
struct LegPostureState {
  Eigen::Map<Eigen::VectorXd> position, velocity;  // q_d, q̇_d (na)
  Eigen::Map<RowMatrixX3> previous_rotations;      // 3n x 3, the feet's orientations last tick
  Eigen::Map<const Eigen::VectorXd> radius;        // n
  const std::vector<std::vector<int>>* joints;     // each leg's joints (indices into na)
  double damping;
};

/// Walking's state between ticks (walking.py Walking; the same names).
struct Walking {
  GaitScheduler scheduler;
  std::vector<Eigen::Vector2d> hips;  // x, y of each foot under its hip
  double height = 0.0;
  Eigen::Vector3d com_offset = Eigen::Vector3d::Zero();
  double full_load = 0.0;
  double cycle_time = 1.0;
  double step_height = 0.0;
  FootholdPlanner footholds = FootholdPlanner::kRobocentric;
  double t = 0.0;
  Eigen::Vector3d command = Eigen::Vector3d::Zero();  // [vx, vy, yaw_rate], rate-limited
  double yaw_ref = 0.0;
  Eigen::Vector3d measured_twist = Eigen::Vector3d::Zero();  // low-passed vx, vy (H), yaw rate
  RowMatrixX3 liftoff;                                       // n x 3
  std::vector<LegEvent> events;                              // this tick's

  /// One tick of the walking pattern generator (Walking.update).
  void update(double t, const WalkingModel& robot, const double* command, const bool* touching,
              WalkingReferences& refs, LegPostureState& posture);

 private:
  void swing_feet(double t, const WalkingModel& robot, double yaw, const bool* stance,
                  WalkingReferences& refs);
  void filter_twist(const WalkingModel& robot, double c, double s, double dt);
};

/// Walking behind the one interface (behaviour.hpp): the walking state and the leg posture's
/// (leg_posture.py LegPostureReference's `_rotations`, `_radius`, `joints`, DAMPING); the
/// posture references are the References' posture and posture_velocity.
class WalkingBehaviour : public NativeBehaviour {
 public:
  Walking walking;
  RowMatrixX3 previous_rotations;        // 3n x 3, the feet's orientations last tick
  Eigen::VectorXd radius;                // n, the foot spheres' radii
  std::vector<std::vector<int>> joints;  // each leg's joints (indices into na)
  double damping = 0.0;

  /// One walking tick (Walking::update) on the references' arrays; throws
  /// std::invalid_argument when they or the model are not sized for n point feet.
  void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) override;
};

}  // namespace lab
