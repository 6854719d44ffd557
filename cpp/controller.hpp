// Kernel: the controller tick of lab/controller/controller.py (WholeBodyController) in one call,
// state (q, v) and references → model update → rows level by level as the stack says →
// hierarchy method → x = [q̈, F] → τ = M_a q̈ + h_a − J_aᵀ F (Herzog eq. 14).
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "constraints.hpp"
#include "hierarchy/problem.hpp"
#include "model.hpp"
#include "references.hpp"
#include "tasks/registry.hpp"

namespace lab {

/// A name the kernel does not know (a task, constraint or method); Python sees a KeyError.
class UnknownName : public std::out_of_range {
 public:
  using std::out_of_range::out_of_range;
};

/// What one tick produced.
struct TickResult {
  Eigen::VectorXd tau, qdd, forces;
  HierarchySolution solution;
};

class Kernel {
 public:
  /// `model`: pinocchio's Model.saveToString() of the Python side's model.
  Kernel(const std::string& model, std::vector<ContactSpec> contacts,
         const Eigen::VectorXd& torque_limits, const Eigen::VectorXd& lower,
         const Eigen::VectorXd& upper, const ContactLimits& limits);
  Kernel(const Kernel&) = delete;
  Kernel& operator=(const Kernel&) = delete;

  /// Tasks, then constraints, in name order.
  std::vector<std::string> known_names() const;
  /// Use a new stack from the next tick on; throws (naming the problem) and keeps the old one.
  void set_stack(const std::vector<std::vector<std::string>>& levels);
  TaskGains set_gains(const std::string& task, std::optional<double> kp, std::optional<double> kd,
                      std::optional<double> weight);
  const TaskGains& gains(const std::string& task) const;
  void set_method(const std::string& method);
  /// `nullspace`'s optimization vector (formulations.hpp): qdd_force, full, qdd_tau, sequential.
  void set_formulation(const std::string& formulation);
  /// Start the next `nullspace` search cold (WholeBodyController.forget_last_solution): the last
  /// tick's active rows and x belong to a state, stack, method or formulation that is gone.
  void forget_last_solution();
  void set_level_weight_ratio(double ratio);
  void set_contact_limits(const ContactLimits& limits);
  void set_torque_limits(const Eigen::VectorXd& limits);
  void set_joint_limits(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper);
  /// The momentum task's K_h (6 × 9), designed on the Python side (lab/controller/momentum.py).
  void set_momentum_gain(const Eigen::Ref<const Eigen::MatrixXd>& gain);
  /// The momentum task's gain schedule, asked on the ticks where no settled K_h holds
  /// (tasks/registry.hpp set_momentum_schedule), and its hold and release.
  void set_momentum_schedule(std::function<void(long)> schedule, double arm_tolerance);
  void hold_momentum_gain(const Eigen::Ref<const Eigen::Array<bool, -1, 1>>& active,
                          const Eigen::Ref<const Eigen::MatrixXd>& arms);
  void blend_momentum_gain(const Eigen::Ref<const Eigen::MatrixXd>& from,
                           const Eigen::Ref<const Eigen::MatrixXd>& to, long step, long length);
  long take_momentum_blend_steps();
  void release_momentum_gain();
  /// The internal-force task's reference (N) and sensed source (`contacts` or `torques`).
  void set_internal_force(double reference, const std::string& source);
  /// The frames the hands task moves, one hand each, and the joints each may use ("all" or
  /// "arm"; empty: all) (WholeBodyController.set_hands); throws std::invalid_argument naming a
  /// frame the model lacks or a bad option and keeps the old ones.
  void set_hands(const std::vector<std::string>& frames, const std::vector<std::string>& joints);
  /// What the sensors measured over the last step, for the internal force's feedback (Kim
  /// eqs. 12–13): the terrain's force on each foot ((n_contacts, 3) flat, N, world) and the joint
  /// torques applied (N m); throws std::invalid_argument for other sizes or non-finite entries.
  void set_sensing(const Eigen::Ref<const Eigen::VectorXd>& foot_forces,
                   const Eigen::Ref<const Eigen::VectorXd>& applied_torques);
  /// The internal force's F_int,act and F_int,cmd per pair at its last rows.
  std::pair<const Eigen::VectorXd&, const Eigen::VectorXd&> internal_force_feedback() const;

  /// The references of the next ticks; check_references() before using them.
  References& references() { return refs_; }
  /// Throws std::invalid_argument naming a field of the wrong size.
  void check_references() const;

  /// The model update alone (validates q and v).
  void update(const Eigen::Ref<const Eigen::VectorXd>& q,
              const Eigen::Ref<const Eigen::VectorXd>& v);
  /// Rows of the current stack at the state of the last update (WholeBodyController.build_problem).
  const HierarchyProblem& build_problem();
  /// Rows, hierarchy method and torques at the state of the last update.
  const TickResult& solve();
  /// One whole tick: update, then solve().
  const TickResult& tick(const Eigen::Ref<const Eigen::VectorXd>& q,
                         const Eigen::Ref<const Eigen::VectorXd>& v);
  /// Norm of each stacked task's tracking error at the last rows (tasks with an error only).
  std::vector<std::pair<std::string, double>> task_errors() const;
  /// f(name, norm) for each stacked task with a tracking error at the last rows, in stack order.
  template <typename F>
  void visit_task_errors(F&& f) const {
    for (const auto& level : stack_)
      for (const auto& [name, task] : level.tasks)
        if (task->error.size()) f(name, task->error.norm());
  }
  /// Seconds the last update() and the last solve() took inside the kernel (steady clock), and
  /// the part of that solve spent building the rows (build_problem: every task's and
  /// constraint's compute); the rest of it is the hierarchy method and the torques.
  double update_seconds() const { return update_seconds_; }
  double solve_seconds() const { return solve_seconds_; }
  double rows_seconds() const { return rows_seconds_; }

  /// One task's or constraint's unweighted rows at the last update, for tests.
  std::pair<Eigen::MatrixXd, Eigen::VectorXd> rows(const std::string& name);

  const RobotModel& robot() const { return robot_; }

  /// Called after every model update (the bindings fill the Python model's arrays with it).
  std::function<void(const RobotModel&)> on_update;
  /// What the Python bindings keep with this kernel (cpp/bindings.cpp), freed with it.
  std::shared_ptr<void> binding_state;
  const std::string& method() const { return method_; }
  const std::string& formulation() const { return formulation_; }

 private:
  Eigen::Index hand_count_ = 0;  // of set_hands: the rows of the references' hand targets
  struct StackLevel {
    std::vector<std::pair<std::string, Task*>> tasks;
    std::vector<Constraint*> constraints;
    std::vector<std::string> constraint_names;  // of `constraints`, for wbosc's report
  };

  Constraint& constraint(const std::string& name);
  /// The nullspace method on problem_, from the last tick's searches (controller.py solve).
  void solve_nullspace_from_last();

  RobotModel robot_;
  References refs_;
  TaskRegistry tasks_;
  ConstraintRegistry constraints_;
  std::vector<StackLevel> stack_;
  std::string method_ = "cascade";
  std::string formulation_ = "qdd_force";
  // nullspace: where the last tick's active-set searches stopped and its x, the next start
  std::vector<ActiveSet> last_active_;
  Eigen::VectorXd last_x_;
  bool has_last_ = false;
  double level_weight_ratio_ = 1e3;
  HierarchyProblem problem_;
  TickResult result_;
  bool updated_ = false;  // solve() needs a state
  double update_seconds_ = 0.0, solve_seconds_ = 0.0, rows_seconds_ = 0.0;
};

}  // namespace lab
