// Squat: the CoG tracks sine curves in double support (Herzog 2016 §5.3); mirrors
// lab/controller/behaviours/squat.py (Squat.update), whose docstring gives the amplitudes.
#pragma once

#include <Eigen/Dense>

#include "behaviours/balance.hpp"

namespace lab {

constexpr double kSquatHold = 0.5;  // s (squat.py HOLD)

/// Squat's state between ticks (squat.py Squat; the same names).
class Squat : public Balance {
 public:
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();     // c₀ (world, m)
  Eigen::Vector3d amplitude = Eigen::Vector3d::Zero();  // m: forward, sideways, vertical
  double period = 2.0;                                  // s
  MotionClock clock;                                    // Python: `start`

  void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) override;
};

}  // namespace lab
