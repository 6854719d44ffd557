// The CoM on an ellipse over two point feet (Kim 2016 Fig. 6b); mirrors
// lab/controller/behaviours/com_ellipse.py (ComEllipse.update), whose docstring gives the sizes:
// c_ref(t) = c₀ + A_u sin(ω t) u + A_z (cos(ω t) − 1) z, leaned off the foot line (balance.cpp).
#pragma once

#include <Eigen/Dense>

#include "behaviours/balance.hpp"

namespace lab {

constexpr double kEllipseHold = 0.5;     // s (com_ellipse.py HOLD)
constexpr double kEllipseAlong = 0.015;  // m, along the foot line
constexpr double kEllipseUp = 0.01;      // m
constexpr double kEllipsePeriod = 4.0;   // s

/// ComEllipse's state between ticks (com_ellipse.py ComEllipse; the same names).
class ComEllipse : public Balance {
 public:
  Eigen::Vector3d along = Eigen::Vector3d::UnitX();  // u, horizontal, from foot 0 to foot 1
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // c₀ (world, m)
  MotionClock clock;                                 // Python: `start`

  void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
              const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) override;
};

}  // namespace lab
