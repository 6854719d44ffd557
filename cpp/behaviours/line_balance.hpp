// Balance about the line between two point feet (Kim 2016 §V; mirrors
// lab/controller/behaviours/line_balance.py, whose docstring derives the law): the CoM reference
// leans off the foot line by d_ref = −(2ζω L_u + ω² I_u θ_u) / (m g).
#pragma once

#include <Eigen/Dense>

#include "behaviours/behaviour.hpp"

namespace lab {

/// ω (rad/s) and ζ of the rotation about the foot line; `max_offset` (m) bounds d_ref
/// (line_balance.py LineBalanceGains; the same defaults).
struct LineBalanceGains {
  double omega = 3.0;
  double damping = 1.0;
  double max_offset = 0.03;
};

/// The horizontal CoM offset (world, m) from the line between contacts 0 and 1 that the law
/// asks for, given the base rotation reference and the whole body's rotational inertia about
/// its CoM (world axes, kg m²).
Eigen::Vector3d line_balance_offset(const BehaviourModel& robot,
                                    const Eigen::Matrix3d& base_rotation_ref,
                                    const Eigen::Matrix3d& inertia, const LineBalanceGains& gains);

}  // namespace lab
