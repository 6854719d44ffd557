// The task registry (lab/controller/tasks/__init__.py TASK_TYPES): every task a stack can name.
#pragma once

#include "tasks/base.hpp"

namespace lab {

// Each module adds its tasks, under the names of the Python registry.
void add_contact_tasks(TaskRegistry& tasks);         // tasks/contact.cpp
void add_trunk_tasks(TaskRegistry& tasks);           // tasks/trunk.cpp
void add_com_tasks(TaskRegistry& tasks);             // tasks/com.cpp
void add_posture_tasks(TaskRegistry& tasks);         // tasks/posture.cpp
void add_objective_tasks(TaskRegistry& tasks);       // tasks/objectives.cpp
void add_feet_tasks(TaskRegistry& tasks);            // tasks/feet.cpp
void add_momentum_tasks(TaskRegistry& tasks);        // tasks/momentum.cpp
void add_sole_tasks(TaskRegistry& tasks);            // tasks/sole.cpp
void add_internal_force_tasks(TaskRegistry& tasks);  // tasks/internal_force.cpp

/// Every task of the Python TASK_TYPES.
TaskRegistry make_tasks();

/// The momentum task's K_h (6 × 9, tasks/momentum.cpp); throws std::invalid_argument for another
/// size or a non-finite entry and keeps the last one.
void set_momentum_gain(Task& momentum, const Eigen::Ref<const Eigen::MatrixXd>& gain);

/// The internal-force task's command F_int,cmd and error (one entry per pair of point feet in
/// support, the error possibly empty) from the Python task's feedback (tasks/internal_force.cpp);
/// throws std::invalid_argument for a non-finite entry or mismatched sizes.
void set_internal_force(Task& internal_force, const Eigen::Ref<const Eigen::VectorXd>& command,
                        const Eigen::Ref<const Eigen::VectorXd>& error);

}  // namespace lab
