// Swing trajectory: the half ellipse of Raiola eqs. 26-29 walked with a warped time, and its
// reaching continuation; mirrors lab/controller/behaviours/swing.py, whose docstring derives it.
#pragma once

#include <Eigen/Core>

namespace lab {

/// Position, velocity and acceleration (world; the rows of the result) at time t after lift-off
/// from `start` towards `target_xy` with step height `height` and swing time `duration`.
Eigen::Matrix3d swing_reference(const Eigen::Vector3d& start, const Eigen::Vector2d& target_xy,
                                double height, double t, double duration);

}  // namespace lab
