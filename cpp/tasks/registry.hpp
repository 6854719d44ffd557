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

/// Every task of the Python TASK_TYPES but those written in Python only (momentum).
TaskRegistry make_tasks();

}  // namespace lab
