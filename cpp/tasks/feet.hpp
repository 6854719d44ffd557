// Which feet swing (lab/controller/tasks/feet.py): the swing_feet task's and moving_posture's.
#pragma once

#include "tasks/base.hpp"

namespace lab {

/// Flags of the point feet out of contact.
Eigen::Array<bool, Eigen::Dynamic, 1> swinging(const RobotModel& robot,
                                               const Eigen::Array<bool, Eigen::Dynamic, 1>& active);

/// Whether the references give the feet swing trajectories (walking references do).
bool has_swing(const References& refs);

}  // namespace lab
