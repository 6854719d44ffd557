// What every task is (lab/controller/tasks/base.py): equality rows A x = b over x = [qdd, F],
// with the task's gains and its tracking error, and the helpers the task modules share.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

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

using TaskRegistry = std::map<std::string, std::unique_ptr<Task>>;

/// The rows of F that belong to the contacts flagged in `flags` (base.py contact_rows), into
/// `rows` (reused from tick to tick: no allocation once it has grown).
void contact_rows(const RobotModel& robot, const Eigen::Array<bool, Eigen::Dynamic, 1>& flags,
                  std::vector<Eigen::Index>& rows);

/// Copy the rows `index` of Jc into the first nv columns of A.
void write_jacobian_rows(const RobotModel& robot, const std::vector<Eigen::Index>& index,
                         Eigen::MatrixXd& A);

}  // namespace lab
