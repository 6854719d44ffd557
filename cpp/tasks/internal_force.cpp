// The internal force between point feet in support (lab/controller/tasks/internal_force.py,
// Kim 2016 §IV): internal_force. The rows W_int λ = F_int,cmd with λ = −F are built here; the
// command of eq. 12, which feeds back the sensed internal force, comes from the Python task
// (InternalForceTask.feedback: the sensing stays there) every tick it is stacked.
#include <stdexcept>
#include <string>

#include "tasks/registry.hpp"

namespace lab {
namespace {

/// Tension between the point feet in support (N, > 0 pushing apart), one row per pair a < b:
/// x̂ᵀ (λ_b − λ_a) with x̂ = (p_b − p_a)/‖p_b − p_a‖ (eqs. 14–17, internal_force.py); the error is
/// the one the Python task measured.
class InternalForceTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    feet_.clear();
    for (std::size_t i = 0; i < robot.contacts.size(); ++i)
      if (refs.contact_active[i] && robot.contacts[i].kind == ContactKind::point)
        feet_.push_back(i);
    const auto n = static_cast<Eigen::Index>(feet_.size());
    if (n < 2) {
      reset(robot, 0);
      error.resize(0);
      return;
    }
    const Eigen::Index pairs = n * (n - 1) / 2;
    if (command.size() != pairs)
      throw std::invalid_argument("internal_force: the command has " +
                                  std::to_string(command.size()) + " entries, the feet in " +
                                  "support make " + std::to_string(pairs) + " pairs");
    reset(robot, pairs);
    Eigen::Index row = 0;
    for (Eigen::Index a = 0; a < n; ++a)
      for (Eigen::Index b = a + 1; b < n; ++b, ++row) {
        const Eigen::Vector3d line =
            robot.contact_positions[feet_[b]] - robot.contact_positions[feet_[a]];
        const Eigen::Vector3d x_hat = line / line.norm();  // R_t's first row (eq. 16)
        // −W_int over F (λ = −F), Δ_t = (I −I) (eq. 17)
        A.row(row).segment<3>(robot.nv + robot.force_starts[feet_[b]]) = -x_hat.transpose();
        A.row(row).segment<3>(robot.nv + robot.force_starts[feet_[a]]) = x_hat.transpose();
      }
    b = command;
    error = feedback_error;
  }

  Eigen::VectorXd command;         // F_int,cmd per pair (eq. 12)
  Eigen::VectorXd feedback_error;  // F_int,ref − F_int,act per pair, or empty
 private:
  std::vector<std::size_t> feet_;  // point feet in support
};

}  // namespace

void set_internal_force(Task& internal_force, const Eigen::Ref<const Eigen::VectorXd>& command,
                        const Eigen::Ref<const Eigen::VectorXd>& error) {
  if (!command.allFinite() || !error.allFinite())
    throw std::invalid_argument("internal_force: the command and error must be finite");
  if (error.size() && error.size() != command.size())
    throw std::invalid_argument("internal_force: the error needs as many entries as the command");
  auto& task = dynamic_cast<InternalForceTask&>(internal_force);
  task.command = command;
  task.feedback_error = error;
}

void add_internal_force_tasks(TaskRegistry& tasks) {
  tasks["internal_force"] = std::make_unique<InternalForceTask>();
}

}  // namespace lab
