// The task registry (lab/controller/tasks/__init__.py TASK_TYPES): every task a stack can name.
#pragma once

#include "tasks/base.hpp"

namespace lab {

// Each module adds its tasks, under the names of the Python registry.
void add_contact_tasks(TaskRegistry& tasks);    // tasks/contact.cpp
void add_trunk_tasks(TaskRegistry& tasks);      // tasks/trunk.cpp
void add_com_tasks(TaskRegistry& tasks);        // tasks/com.cpp
void add_posture_tasks(TaskRegistry& tasks);    // tasks/posture.cpp
void add_objective_tasks(TaskRegistry& tasks);  // tasks/objectives.cpp
void add_feet_tasks(TaskRegistry& tasks);       // tasks/feet.cpp
void add_momentum_tasks(TaskRegistry& tasks);   // tasks/momentum.cpp
void add_sole_tasks(TaskRegistry& tasks);       // tasks/sole.cpp

/// Every task of the Python TASK_TYPES but those written in Python only (internal_force,
/// com_along_feet, com_across_feet).
TaskRegistry make_tasks();

/// The momentum task's K_h (6 × 9, tasks/momentum.cpp); throws std::invalid_argument for another
/// size or a non-finite entry and keeps the last one.
void set_momentum_gain(Task& momentum, const Eigen::Ref<const Eigen::MatrixXd>& gain);

}  // namespace lab
