// What the posture tasks share with swing_leg (lab/controller/tasks/posture.py leg_joints).
#pragma once

#include <vector>

#include "tasks/base.hpp"

namespace lab {

/// Actuated-joint indices of each contact's leg: the joints that move the contact point.
std::vector<std::vector<Eigen::Index>> leg_joints(const RobotModel& robot);

}  // namespace lab
