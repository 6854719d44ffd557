// The internal force between point feet in support, with sensor feedback (mirrors
// lab/controller/tasks/internal_force.py, Kim 2016 §IV): internal_force. Rows W_int λ = F_int,cmd
// with λ = −F and the command of eq. 12, F_int,cmd = F_int,ref + K_F (F_int,ref − F_int,act), K_F
// the task's kp; F_int,act sensed from the feet's measured forces of the last step (`contacts`)
// or from the torques applied over it through the contact-consistent dynamics (`torques`,
// eq. 13). Both are handed over by set_internal_force_sensing every tick the session measures.
#include "internal_force.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

#include "contact_dynamics.hpp"
#include "tasks/registry.hpp"

namespace lab {
namespace {

/// Tension between the point feet in support (N, > 0 pushing apart), one row per pair a < b:
/// x̂ᵀ (λ_b − λ_a) with x̂ = (p_b − p_a)/‖p_b − p_a‖ (eqs. 14–17); the error is F_int,ref −
/// F_int,act (empty before the first sensed step).
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
      sensed.resize(0);
      command.resize(0);
      return;
    }
    const Eigen::Index pairs = n * (n - 1) / 2;
    if (sense(robot, refs)) {  // feedback (eq. 12)
      error = Eigen::VectorXd::Constant(pairs, reference) - sensed;
      command = Eigen::VectorXd::Constant(pairs, reference) + gains.kp * error;
    } else {
      error.resize(0);
      command.setConstant(pairs, reference);
    }
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
  }

  double reference = 0.0;     // F_int,ref (N), the same for every pair of feet
  bool from_torques = false;  // source: the applied torques (else the measured forces)
  Eigen::VectorXd measured;   // the terrain's force on each foot, (n_contacts, 3) flat
  Eigen::VectorXd applied;    // the torques applied over the last step
  Eigen::VectorXd sensed;     // F_int,act per pair at the last rows (empty: none)
  Eigen::VectorXd command;    // F_int,cmd per pair at the last rows

 private:
  /// _sensed: F_int,act from the chosen source into `sensed`; false before the first sensed step.
  bool sense(const RobotModel& robot, const References& refs) {
    const auto n = static_cast<Eigen::Index>(feet_.size());
    foot_forces_.resize(3 * n);
    if (!from_torques) {
      if (!measured.size()) return false;
      for (Eigen::Index k = 0; k < n; ++k)
        foot_forces_.segment<3>(3 * k) = measured.segment<3>(3 * feet_[k]);
    } else {
      if (!applied.size()) return false;
      contact_rows(robot, refs.contact_active, rows_);
      const auto ns = static_cast<Eigen::Index>(rows_.size());
      Js_.resize(ns, robot.nv);
      drift_.resize(ns);
      for (Eigen::Index r = 0; r < ns; ++r) {
        Js_.row(r) = robot.Jc.row(rows_[r]);
        drift_[r] = robot.Jc_dot_v[rows_[r]];
      }
      dynamics_.compute(robot.M, robot.h, Js_, drift_);
      forces_ = dynamics_.force_free;  // eq. 13: F = D τ + F₀
      forces_.noalias() += dynamics_.force_of_torque * applied;
      // Each active contact's block of `forces_`, in contact order; a point foot's first 3.
      Eigen::Index offset = 0, k = 0;
      for (std::size_t i = 0; i < robot.contacts.size(); ++i) {
        if (!refs.contact_active[i]) continue;
        if (k < n && feet_[k] == i) foot_forces_.segment<3>(3 * k++) = forces_.segment<3>(offset);
        offset += robot.contacts[i].force_dim();
      }
    }
    internal_forces(robot.contact_positions, feet_, foot_forces_, sensed);
    return true;
  }

  std::vector<std::size_t> feet_;   // point feet in support
  std::vector<Eigen::Index> rows_;  // rows of F of the contacts in support
  Eigen::VectorXd foot_forces_, drift_, forces_;
  Eigen::MatrixXd Js_;
  ContactDynamics dynamics_;
};

InternalForceTask& as_internal_force(Task& task) { return dynamic_cast<InternalForceTask&>(task); }

}  // namespace

void set_internal_force(Task& internal_force, double reference, const std::string& source) {
  if (!std::isfinite(reference))
    throw std::invalid_argument("internal_force: the reference must be finite");
  if (source != "contacts" && source != "torques")
    throw std::invalid_argument("internal_force: unknown source '" + source +
                                "' (sources: contacts, torques)");
  auto& task = as_internal_force(internal_force);
  task.reference = reference;
  task.from_torques = source == "torques";
}

void set_internal_force_sensing(Task& internal_force,
                                const Eigen::Ref<const Eigen::VectorXd>& foot_forces,
                                const Eigen::Ref<const Eigen::VectorXd>& applied_torques) {
  auto& task = as_internal_force(internal_force);
  task.measured = foot_forces;
  task.applied = applied_torques;
}

std::pair<const Eigen::VectorXd&, const Eigen::VectorXd&> internal_force_feedback(
    const Task& internal_force) {
  const auto& task = dynamic_cast<const InternalForceTask&>(internal_force);
  return {task.sensed, task.command};
}

void add_internal_force_tasks(TaskRegistry& tasks) {
  tasks["internal_force"] = std::make_unique<InternalForceTask>();
}

}  // namespace lab
