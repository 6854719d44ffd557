#include "tasks/registry.hpp"

namespace lab {

TaskRegistry make_tasks() {
  TaskRegistry tasks;
  add_contact_tasks(tasks);
  add_trunk_tasks(tasks);
  add_com_tasks(tasks);
  add_posture_tasks(tasks);
  add_objective_tasks(tasks);
  add_feet_tasks(tasks);
  add_momentum_tasks(tasks);
  add_sole_tasks(tasks);
  add_internal_force_tasks(tasks);
  add_hands_tasks(tasks);
  return tasks;
}

}  // namespace lab
