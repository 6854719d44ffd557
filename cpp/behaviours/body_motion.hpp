// Scripted body motions on four feet, the inputs of Hutter 2014 Sim5 and Exp6/Exp7; mirrors
// lab/controller/behaviours/body_motion.py (HeightStep.update, ForwardShift.update).
#pragma once

#include <Eigen/Dense>

#include "behaviours/behaviour.hpp"
#include "behaviours/static_walk.hpp"

namespace lab {

constexpr double kMotionHold = 0.5;   // s (body_motion.py HOLD)
constexpr double kHeightStep = 0.08;  // m, downwards
constexpr double kShift = 0.25;       // m, forwards
constexpr double kShiftTime = 2.0;    // s

/// HeightStep's state (body_motion.py; Hutter 2014 Exp6): stand, then lower the CoM and base
/// height references by kHeightStep after kMotionHold s.
class HeightStep : public NativeBehaviour {
 public:
  Eigen::Vector3d com = Eigen::Vector3d::Zero();  // the standing CoM (world, m)
  double height = 0.0;                            // the standing base height (m)
  MotionClock clock;

  void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) override;
};

/// ForwardShift's state (body_motion.py; Hutter 2014 Exp7): stand, then shift the CoM reference
/// forward (world x) by kShift over kShiftTime s on a minimum-jerk path.
class ForwardShift : public NativeBehaviour {
 public:
  Eigen::Vector3d com = Eigen::Vector3d::Zero();  // the standing CoM (world, m)
  MotionClock clock;

  void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) override;
};

}  // namespace lab
