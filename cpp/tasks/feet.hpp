// Which feet swing (lab/controller/tasks/feet.py): the swing_feet task's and moving_posture's.
#pragma once

#include "tasks/base.hpp"

namespace lab {

/// Flags of the point feet out of contact.
Eigen::Array<bool, Eigen::Dynamic, 1> swinging(const RobotModel& robot,
                                               const Eigen::Array<bool, Eigen::Dynamic, 1>& active);

/// Flags of the point feet the swing_feet task moves (feet.py's `_not_tracked` and `SwingRows.of`):
/// those `refs.swing_tracked` names when it has one flag per contact, else those out of contact.
void tracked(const RobotModel& robot, const References& refs,
             Eigen::Array<bool, Eigen::Dynamic, 1>& out);

/// Whether the references give the feet swing trajectories (walking references do).
bool has_swing(const References& refs);

}  // namespace lab
