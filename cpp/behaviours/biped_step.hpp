// Stepping on two point feet: the state machine of Kim 2016 Fig. 8a with the footstep planner of
// §V (pipm.cpp); mirrors lab/controller/behaviours/biped_step.py (BipedStepping.update, _plan,
// _retime), whose docstring explains each reference. The Python BipedStepping keeps the state
// between ticks and the bindings (behaviours/python.cpp) load it into this struct and write it
// back; on a native tick one call runs the whole tick below.
#pragma once

#include <Eigen/Core>
#include <array>

#include "behaviours/behaviour.hpp"
#include "behaviours/leg_posture.hpp"

namespace lab {

/// The phases of Fig. 8a (biped_step.py Phase).
enum class StepPhase { kDual, kLiftTransition, kLift, kLand, kLandTransition };

/// The phases' durations and the planner's parameters (biped_step.py SteppingTimes).
struct SteppingTimes {
  double dual, transition, lift, land, step_height, reversal_time, impact_velocity_change,
      replan_from, reach, lateral_offset, min_width, max_width, min_swing, max_lateral_speed,
      min_lateral_speed, max_swing;
};

/// What the stepping tick reads of the robot model (the arrays the native kernel's update
/// fills; world axes).
struct BipedModel {
  Eigen::Map<const Eigen::VectorXd> q;
  Eigen::Map<const RowMatrix3> base_rotation;
  Eigen::Map<const RowMatrixX3> contact_positions;  // 2 x 3
  Eigen::Map<const Eigen::Vector3d> com, com_velocity;
};

/// The references the stepping tick writes (the WalkReferences' arrays, in place).
struct BipedReferences {
  bool* contact_active;                                                     // 2
  bool* swing_tracked;                                                      // 2
  Eigen::Map<Eigen::Vector2d> force_weight;                                 // NaN: no ramp
  Eigen::Map<RowMatrixX3> foot_position, foot_velocity, foot_acceleration;  // 2 x 3 each
  Eigen::Map<Eigen::VectorXd> posture;                                      // na
  Eigen::Map<RowMatrix3> base_rotation;
  Eigen::Map<Eigen::Vector3d> base_angular_velocity, com;
  double base_height;
};

/// The number of the last plan's inputs (biped_step.py PLAN_FIELDS).
constexpr int kPlanFields = 11;

/// BipedStepping's state between ticks (biped_step.py BipedStepping; the same names).
struct BipedStepping {
  SteppingTimes times{};
  double height = 0.0, com_height = 0.0;
  double yaw = 0.0, t = 0.0;  // the heading reference (rad) and the last tick's time (s)
  bool started = false;       // a tick has run (Python: `since` is not None)
  Eigen::Vector3d command = Eigen::Vector3d::Zero();  // [vx, vy, yaw_rate], rate-limited
  Eigen::Vector2d sides = Eigen::Vector2d::Zero();
  int swing = 0;
  StepPhase phase = StepPhase::kDual;
  double since = 0.0;
  Eigen::Vector3d liftoff = Eigen::Vector3d::Zero();
  Eigen::Vector2d target = Eigen::Vector2d::Zero();
  double swing_start = 0.0, swing_t0 = 0.0, swing_u0 = 0.0, swing_duration = 0.0;
  long shortened = 0, lengthened = 0, steps = 0, plans = 0;
  std::array<double, kPlanFields> plan{};

  /// One tick of the state machine (BipedStepping.update) at time `t_now` (s); `commanded` is the
  /// velocity command [vx, vy, yaw_rate], `touching` one flag per foot.
  void update(double t_now, const BipedModel& robot, const double* commanded, const bool* touching,
              BipedReferences& refs);

 private:
  void enter(StepPhase next, double t_now);
  double lift_fraction() const;
  double swing_done(double t_now) const;
  void retime(double t_now, double switch_in);
  Eigen::Vector2d plan_footstep(const BipedModel& robot, double t_now);
};

/// BipedStepping behind the one interface (behaviour.hpp).
class BipedSteppingBehaviour : public NativeBehaviour {
 public:
  BipedStepping stepping;

  /// One stepping tick (BipedStepping::update) on the references' arrays; throws
  /// std::invalid_argument when they or the model are not sized for two point feet.
  void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) override;
};

}  // namespace lab
