// Helpers the task modules share (tasks.cpp defines them).
#pragma once

#include <memory>
#include <vector>

#include "tasks.hpp"

namespace lab {

/// Copy the rows `index` of Jc into the first nv columns of A.
void write_jacobian_rows(const RobotModel& robot, const std::vector<Eigen::Index>& index,
                         Eigen::MatrixXd& A);

/// The `com` task, which `com_xy` (walk_tasks.cpp) builds on.
std::unique_ptr<Task> make_com_task();

}  // namespace lab
