// The task registry (lab/controller/tasks/__init__.py TASK_TYPES): every task a stack can name.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

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
void add_hands_tasks(TaskRegistry& tasks);           // tasks/hands.cpp

/// Every task of the Python TASK_TYPES.
TaskRegistry make_tasks();

/// The momentum task's K_h (6 × 9, tasks/momentum.cpp); throws std::invalid_argument for another
/// size or a non-finite entry and keeps the last one.
void set_momentum_gain(Task& momentum, const Eigen::Ref<const Eigen::MatrixXd>& gain);
/// The momentum task asks `schedule` (the Python gain schedule, which sets K_h and holds it
/// when its target stays) on every tick where no held K_h holds for the contact configuration
/// and pose: a contact arm moved more than `arm_tolerance` (m) from the held pose (an empty
/// `schedule`: K_h only from set_momentum_gain); it passes the blend steps made since the
/// last ask. Drops the held gain and its blend.
void set_momentum_schedule(Task& momentum, std::function<void(long)> schedule,
                           double arm_tolerance);
/// Hold the current K_h as settled for the contacts `active` at the arms p_i − c (one row per
/// contact in support, world axes) its design read; throws std::invalid_argument for others.
void hold_momentum_gain(Task& momentum, const Eigen::Ref<const Eigen::Array<bool, -1, 1>>& active,
                        const Eigen::Ref<const Eigen::MatrixXd>& arms);
/// While held, K_h moves from `from` to `to` (6 × 9 each) over `length` ticks, `step` of them
/// made (GainSchedule.gain's interpolation); throws std::invalid_argument for others.
void blend_momentum_gain(Task& momentum, const Eigen::Ref<const Eigen::MatrixXd>& from,
                         const Eigen::Ref<const Eigen::MatrixXd>& to, long step, long length);
/// The blend steps made since the schedule was last asked (or since this was last called), and
/// count from zero again: what GainSchedule.skip catches up with.
long take_momentum_blend_steps(Task& momentum);
/// The next tick asks the schedule again (the Python schedule changed outside a tick).
void release_momentum_gain(Task& momentum);

/// The frames the hands task moves, one hand each, in the order of the references' hand rows,
/// and the joints each may use, "all" or "arm" (tasks/hands.cpp; empty: all); throws
/// std::invalid_argument naming a frame the model lacks or a bad option and keeps the old ones
/// then.
void set_hand_frames(Task& hands, const RobotModel& robot, const std::vector<std::string>& frames,
                     const std::vector<std::string>& joints);

/// The internal-force task's reference F_int,ref (N) and where F_int,act comes from (`contacts`
/// or `torques`, tasks/internal_force.cpp); throws std::invalid_argument for a non-finite
/// reference or another source.
void set_internal_force(Task& internal_force, double reference, const std::string& source);
/// What was sensed over the last step for the feedback of Kim eq. 12: the terrain's force on
/// each foot ((n_contacts, 3) flat, world) and the joint torques applied (sizes checked by the
/// Kernel).
void set_internal_force_sensing(Task& internal_force,
                                const Eigen::Ref<const Eigen::VectorXd>& foot_forces,
                                const Eigen::Ref<const Eigen::VectorXd>& applied_torques);
/// F_int,act and F_int,cmd per pair at the task's last rows (empty with fewer than two point
/// feet in support; F_int,act also before the first sensed step).
std::pair<const Eigen::VectorXd&, const Eigen::VectorXd&> internal_force_feedback(
    const Task& internal_force);

}  // namespace lab
