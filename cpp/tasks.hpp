// Tasks and constraints: rows over x = [qdd, F] (mirrors lab/controller/tasks.py and
// constraints.py). One .cpp per Python module: tasks.cpp, trunk_tasks.cpp, objectives.cpp,
// walk_tasks.cpp, constraints.cpp, with the same rows in the same order and signs.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "model.hpp"
#include "references.hpp"

namespace lab {

/// PD gains and the weight of a task inside its level.
struct TaskGains {
  double kp = 0.0;
  double kd = 0.0;
  double weight = 1.0;
};

/// A producer of equality rows A x = b. `compute` rewrites A (zero where not written), b and
/// the tracking error of this tick.
class Task {
 public:
  virtual ~Task() = default;
  virtual void compute(const RobotModel& robot, const References& refs) = 0;

  TaskGains gains;
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  Eigen::VectorXd error;

 protected:
  /// n zero rows over x (the error is the task's to set; a task without one leaves it empty).
  void reset(const RobotModel& robot, Eigen::Index n);
};

/// A producer of inequality rows C x <= d.
class Constraint {
 public:
  virtual ~Constraint() = default;
  virtual void compute(const RobotModel& robot, const References& refs) = 0;

  Eigen::MatrixXd C;
  Eigen::VectorXd d;

 protected:
  void reset(const RobotModel& robot, Eigen::Index n);
};

/// Friction and normal-force bounds shared by every contact (constraints.py ContactLimits).
struct ContactLimits {
  double friction = 0.8;
  double normal_min = 0.0;
  double normal_max = 5000.0;
};

using TaskRegistry = std::map<std::string, std::unique_ptr<Task>>;
using ConstraintRegistry = std::map<std::string, std::unique_ptr<Constraint>>;

// Each module adds its tasks, under the names of the Python registry.
void add_tasks(TaskRegistry& tasks);        // tasks.cpp
void add_trunk_tasks(TaskRegistry& tasks);  // trunk_tasks.cpp
void add_objectives(TaskRegistry& tasks);   // objectives.cpp
void add_walk_tasks(TaskRegistry& tasks);   // walk_tasks.cpp

/// Every task of the Python TASK_TYPES.
TaskRegistry make_tasks();

/// The constraints of a robot: friction, torque_limits, joint_limits, and cop with flat feet.
ConstraintRegistry make_constraints(const RobotModel& robot, const ContactLimits& limits,
                                    const Eigen::VectorXd& torque_limits,
                                    const Eigen::VectorXd& lower, const Eigen::VectorXd& upper);

// Setters of the constraints' parameters (constraints.cpp); names as in the registry.
void set_contact_limits(Constraint& friction, const ContactLimits& limits);
void set_torque_limits(Constraint& torque_limits, const Eigen::VectorXd& limits);
void set_joint_limits(Constraint& joint_limits, const Eigen::VectorXd& lower,
                      const Eigen::VectorXd& upper);

/// The rows of F that belong to the contacts flagged in `flags` (tasks.py contact_rows), into
/// `rows` (reused from tick to tick: no allocation once it has grown).
void contact_rows(const RobotModel& robot, const Eigen::Array<bool, Eigen::Dynamic, 1>& flags,
                  std::vector<Eigen::Index>& rows);

}  // namespace lab
