#include "controller.hpp"

#include <chrono>
#include <cmath>
#include <set>

#include "hierarchy/formulations.hpp"

namespace lab {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void check_finite(const Eigen::Ref<const Eigen::VectorXd>& x, const char* what, Eigen::Index n) {
  if (x.size() != n)
    throw std::invalid_argument(std::string(what) + " has " + std::to_string(x.size()) +
                                " entries, the model needs " + std::to_string(n));
  if (!x.allFinite()) throw std::invalid_argument(std::string(what) + " has non-finite entries");
}

void check_size(Eigen::Index size, std::initializer_list<Eigen::Index> allowed, const char* what) {
  for (auto n : allowed)
    if (size == n) return;
  std::string sizes;
  for (auto n : allowed) sizes += (sizes.empty() ? "" : " or ") + std::to_string(n);
  throw std::invalid_argument(std::string("references: ") + what + " has " + std::to_string(size) +
                              " entries, expected " + sizes);
}

}  // namespace

Kernel::Kernel(const std::string& model, std::vector<ContactSpec> contacts,
               const Eigen::VectorXd& torque_limits, const Eigen::VectorXd& lower,
               const Eigen::VectorXd& upper, const ContactLimits& limits)
    : robot_(model, std::move(contacts)), tasks_(make_tasks()) {
  check_size(torque_limits.size(), {robot_.na}, "torque_limits");
  check_size(lower.size(), {robot_.na}, "lower joint limits");
  check_size(upper.size(), {robot_.na}, "upper joint limits");
  constraints_ = make_constraints(robot_, limits, torque_limits, lower, upper);
  const auto n_contacts = static_cast<Eigen::Index>(robot_.contacts.size());
  refs_.posture = robot_.q.tail(robot_.na);
  refs_.contact_active.setConstant(n_contacts, true);
  problem_.dynamics_A.resize(BASE_DOF, robot_.nx);
  problem_.dynamics_b.resize(BASE_DOF);
  result_.tau.setZero(robot_.na);
  result_.qdd.setZero(robot_.nv);
  result_.forces.setZero(robot_.nf);
}

std::vector<std::string> Kernel::known_names() const {
  std::vector<std::string> names;
  for (const auto& [name, task] : tasks_) names.push_back(name);
  for (const auto& [name, constraint] : constraints_) names.push_back(name);
  return names;
}

void Kernel::set_stack(const std::vector<std::vector<std::string>>& levels) {
  if (levels.empty()) throw std::invalid_argument("the stack has no levels");
  std::vector<StackLevel> stack;
  std::set<std::string> seen;
  for (std::size_t i = 0; i < levels.size(); ++i) {
    if (levels[i].empty())
      throw std::invalid_argument("level " + std::to_string(i + 1) + " is empty");
    StackLevel level;
    for (const auto& name : levels[i]) {
      if (!seen.insert(name).second)
        throw std::invalid_argument("task '" + name + "' appears twice");
      if (auto task = tasks_.find(name); task != tasks_.end())
        level.tasks.emplace_back(name, task->second.get());
      else if (auto c = constraints_.find(name); c != constraints_.end()) {
        level.constraints.push_back(c->second.get());
        level.constraint_names.push_back(name);
      } else
        throw UnknownName("the native kernel has no task or constraint '" + name + "'");
    }
    stack.push_back(std::move(level));
  }
  stack_ = std::move(stack);
  forget_last_solution();  // its active rows are rows of the old stack
}

TaskGains Kernel::set_gains(const std::string& task, std::optional<double> kp,
                            std::optional<double> kd, std::optional<double> weight) {
  auto found = tasks_.find(task);
  if (found == tasks_.end()) throw UnknownName("unknown task '" + task + "'");
  for (auto value : {kp, kd, weight})
    if (value && !std::isfinite(*value))
      throw std::invalid_argument("gains of '" + task + "' must be finite");
  auto& gains = found->second->gains;
  if (kp) gains.kp = *kp;
  if (kd) gains.kd = *kd;
  if (weight) gains.weight = *weight;
  return gains;
}

const TaskGains& Kernel::gains(const std::string& task) const {
  auto found = tasks_.find(task);
  if (found == tasks_.end()) throw UnknownName("unknown task '" + task + "'");
  return found->second->gains;
}

void Kernel::set_method(const std::string& method) {
  if (method != "cascade" && method != "weighted" && method != "nullspace" && method != "wbosc")
    throw UnknownName("the native kernel has no hierarchy method '" + method +
                      "' (methods: cascade, weighted, nullspace, wbosc)");
  if (method != method_) forget_last_solution();  // another method's levels
  method_ = method;
}

void Kernel::set_formulation(const std::string& formulation) {
  if (!is_formulation(formulation))
    throw UnknownName("unknown formulation '" + formulation +
                      "' (formulations: qdd_force, full, qdd_tau, sequential)");
  if (formulation != formulation_) forget_last_solution();  // another formulation's levels
  formulation_ = formulation;
}

void Kernel::forget_last_solution() { has_last_ = false; }

void Kernel::set_level_weight_ratio(double ratio) {
  if (!(ratio > 0.0) || !std::isfinite(ratio))
    throw std::invalid_argument("level_weight_ratio must be a positive number");
  level_weight_ratio_ = ratio;
}

Constraint& Kernel::constraint(const std::string& name) { return *constraints_.at(name); }

void Kernel::set_contact_limits(const ContactLimits& limits) {
  lab::set_contact_limits(constraint("friction"), limits);
  if (auto torsion = constraints_.find("sole_torsion"); torsion != constraints_.end())
    lab::set_contact_limits(*torsion->second, limits);
}

void Kernel::set_torque_limits(const Eigen::VectorXd& limits) {
  check_size(limits.size(), {robot_.na}, "torque_limits");
  lab::set_torque_limits(constraint("torque_limits"), limits);
}

void Kernel::set_joint_limits(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper) {
  check_size(lower.size(), {robot_.na}, "lower joint limits");
  check_size(upper.size(), {robot_.na}, "upper joint limits");
  lab::set_joint_limits(constraint("joint_limits"), lower, upper);
}

void Kernel::set_momentum_gain(const Eigen::Ref<const Eigen::MatrixXd>& gain) {
  lab::set_momentum_gain(*tasks_.at("momentum"), gain);
}

void Kernel::set_momentum_schedule(std::function<void(long)> schedule, double arm_tolerance) {
  lab::set_momentum_schedule(*tasks_.at("momentum"), std::move(schedule), arm_tolerance);
}

void Kernel::hold_momentum_gain(const Eigen::Ref<const Eigen::Array<bool, -1, 1>>& active,
                                const Eigen::Ref<const Eigen::MatrixXd>& arms) {
  lab::hold_momentum_gain(*tasks_.at("momentum"), active, arms);
}

void Kernel::blend_momentum_gain(const Eigen::Ref<const Eigen::MatrixXd>& from,
                                 const Eigen::Ref<const Eigen::MatrixXd>& to, long step,
                                 long length) {
  lab::blend_momentum_gain(*tasks_.at("momentum"), from, to, step, length);
}

long Kernel::take_momentum_blend_steps() {
  return lab::take_momentum_blend_steps(*tasks_.at("momentum"));
}

void Kernel::release_momentum_gain() { lab::release_momentum_gain(*tasks_.at("momentum")); }

void Kernel::set_internal_force(double reference, const std::string& source) {
  lab::set_internal_force(*tasks_.at("internal_force"), reference, source);
}

void Kernel::set_hands(const std::vector<std::string>& frames,
                       const std::vector<std::string>& joints) {
  lab::set_hand_frames(*tasks_.at("hands"), robot_, frames, joints);
  hand_count_ = static_cast<Eigen::Index>(frames.size());
}

void Kernel::set_sensing(const Eigen::Ref<const Eigen::VectorXd>& foot_forces,
                         const Eigen::Ref<const Eigen::VectorXd>& applied_torques) {
  check_finite(foot_forces, "sensing: foot_forces",
               3 * static_cast<Eigen::Index>(robot_.contacts.size()));
  check_finite(applied_torques, "sensing: applied_torques", robot_.na);
  lab::set_internal_force_sensing(*tasks_.at("internal_force"), foot_forces, applied_torques);
}

std::pair<const Eigen::VectorXd&, const Eigen::VectorXd&> Kernel::internal_force_feedback() const {
  return lab::internal_force_feedback(*tasks_.at("internal_force"));
}

void Kernel::check_references() const {
  const auto n = static_cast<Eigen::Index>(robot_.contacts.size());
  check_size(refs_.posture.size(), {robot_.na}, "posture");
  check_size(refs_.contact_active.size(), {n}, "contact_active");
  check_size(refs_.normal_force_max.size(), {0, n}, "normal_force_max");
  check_size(refs_.foot_position.size(), {0, 3 * n}, "foot_position");
  if (refs_.foot_position.size()) {
    check_size(refs_.foot_velocity.size(), {3 * n}, "foot_velocity");
    check_size(refs_.foot_acceleration.size(), {3 * n}, "foot_acceleration");
  }
  check_size(refs_.force_weight.size(), {0, n}, "force_weight");
  check_size(refs_.swing_tracked.size(), {0, n}, "swing_tracked");
  check_size(refs_.sole_position.size(), {0, 3 * n}, "sole_position");
  if (refs_.sole_position.size()) check_size(refs_.sole_rotation.size(), {9 * n}, "sole_rotation");
  check_size(refs_.hand_position.size(), {0, 3 * hand_count_}, "hand_position");
  if (refs_.hand_position.size()) {
    check_size(refs_.hand_velocity.size(), {3 * hand_count_}, "hand_velocity");
    check_size(refs_.hand_acceleration.size(), {3 * hand_count_}, "hand_acceleration");
    check_size(refs_.hand_rotation.size(), {9 * hand_count_}, "hand_rotation");
    check_size(refs_.hand_heading.size(), {0, hand_count_}, "hand_heading");
  }
  check_size(refs_.leg_swinging.size(), {0, n}, "leg_swinging");
  if (refs_.leg_swinging.size() && (refs_.leg_swinging && !refs_.contact_active).any()) {
    check_size(refs_.leg_position.size(), {robot_.na}, "leg_position");
    check_size(refs_.leg_velocity.size(), {robot_.na}, "leg_velocity");
    check_size(refs_.leg_acceleration.size(), {robot_.na}, "leg_acceleration");
  }
}

void Kernel::update(const Eigen::Ref<const Eigen::VectorXd>& q,
                    const Eigen::Ref<const Eigen::VectorXd>& v) {
  const auto start = Clock::now();
  check_finite(q, "q", robot_.nq);
  check_finite(v, "v", robot_.nv);
  robot_.update(q, v);
  updated_ = true;
  if (on_update) on_update(robot_);
  update_seconds_ = seconds_since(start);
}

const HierarchyProblem& Kernel::build_problem() {
  const RobotModel& robot = robot_;
  const Eigen::Index nx = robot.nx, nv = robot.nv;
  // Newton–Euler rows (Herzog eq. 13): M_u q̈ − J_uᵀ F = −h_u.
  problem_.dynamics_A.leftCols(nv) = robot.M.topRows<BASE_DOF>();
  problem_.dynamics_A.rightCols(robot.nf) = -robot.Jc.leftCols<BASE_DOF>().transpose();
  problem_.dynamics_b = -robot.h.head<BASE_DOF>();
  problem_.levels.resize(stack_.size());
  double weight = 1.0;  // of the next level with tasks; inequality-only levels take no weight
  for (std::size_t l = 0; l < stack_.size(); ++l) {
    Level& level = problem_.levels[l];
    Eigen::Index m = 0, k = 0;
    for (auto& [name, task] : stack_[l].tasks) {
      task->compute(robot, refs_);
      m += task->A.rows();
    }
    for (Constraint* constraint : stack_[l].constraints) {
      constraint->compute(robot, refs_);
      k += constraint->C.rows();
    }
    level.A.resize(m, nx);
    level.b.resize(m);
    level.C.resize(k, nx);
    level.d.resize(k);
    m = 0;
    for (auto& [name, task] : stack_[l].tasks) {
      const Eigen::Index rows = task->A.rows();
      if (task->gains.weight != 1.0) {  // the task's weight folded in as √w on A and b
        const double scale = std::sqrt(task->gains.weight);
        level.A.middleRows(m, rows) = scale * task->A;
        level.b.segment(m, rows) = scale * task->b;
      } else {
        level.A.middleRows(m, rows) = task->A;
        level.b.segment(m, rows) = task->b;
      }
      m += rows;
    }
    k = 0;
    level.constraint_rows.resize(stack_[l].constraints.size());
    for (std::size_t c = 0; c < stack_[l].constraints.size(); ++c) {
      const Constraint* constraint = stack_[l].constraints[c];
      level.C.middleRows(k, constraint->C.rows()) = constraint->C;
      level.d.segment(k, constraint->C.rows()) = constraint->d;
      level.constraint_rows[c] = {stack_[l].constraint_names[c], constraint->C.rows()};
      k += constraint->C.rows();
    }
    level.weight = weight;
    if (!stack_[l].tasks.empty()) weight /= level_weight_ratio_;
  }
  robot.force_rows_of(refs_.contact_active, problem_.support);
  if (method_ == "wbosc") {  // its contact-consistent dynamics (controller.py DynamicsTerms)
    DynamicsTerms& terms = problem_.terms;
    terms.M = &robot.M;
    terms.h = &robot.h;
    terms.Jc = &robot.Jc;
    terms.drift = &robot.Jc_dot_v;
    // _transition_weights: each row of F of a contact being loaded or unloaded, NaN elsewhere.
    const auto n = static_cast<Eigen::Index>(robot.contacts.size());
    terms.transition.resize(refs_.force_weight.size() == n ? robot.nf : 0);
    if (terms.transition.size())
      for (Eigen::Index i = 0; i < n; ++i)
        terms.transition.segment(robot.force_starts[i], robot.contacts[i].force_dim())
            .setConstant(refs_.force_weight[i]);
  }
  return problem_;
}

const TickResult& Kernel::tick(const Eigen::Ref<const Eigen::VectorXd>& q,
                               const Eigen::Ref<const Eigen::VectorXd>& v) {
  update(q, v);
  return solve();
}

const TickResult& Kernel::solve() {
  if (stack_.empty()) throw std::logic_error("the kernel has no stack: call set_stack first");
  if (!updated_) throw std::logic_error("the kernel has no state: call update first");
  const auto start = Clock::now();
  check_references();
  const HierarchyProblem& problem = build_problem();
  rows_seconds_ = seconds_since(start);
  result_.solution.violations.clear();  // only wbosc reports them
#ifdef LAB_HAVE_HIERARCHY_SOLVERS
  if (method_ == "cascade") {
    solve_cascade(problem, result_.solution);
  } else if (method_ == "weighted") {
    solve_weighted(problem, result_.solution);
  } else if (method_ == "wbosc") {
    solve_wbosc(problem, result_.solution);
  } else {
    solve_nullspace_from_last();
  }
#else
  (void)problem;
  throw std::runtime_error("the native hierarchy solvers are not built (cpp/hierarchy)");
#endif
  if (result_.solution.ok) {
    const auto& x = result_.solution.x;
    result_.qdd = x.head(robot_.nv);
    result_.forces = x.tail(robot_.nf);
    robot_.joint_torques(x, result_.tau);
  }
  solve_seconds_ = seconds_since(start);
  return result_;
}

void Kernel::solve_nullspace_from_last() {
  // The model terms and the last tick's searches, as WholeBodyController.solve hands them over.
  HierarchyProblem& problem = problem_;
  problem.terms.M = &robot_.M;
  problem.terms.h = &robot_.h;
  problem.terms.Jc = &robot_.Jc;
  problem.formulation = formulation_;
  problem.active_start = has_last_ ? &last_active_ : nullptr;
  problem.x_start = has_last_ ? &last_x_ : nullptr;
  solve_nullspace(problem, result_.solution);
  has_last_ = result_.solution.ok;
  if (has_last_) {
    last_active_ = result_.solution.active_sets;
    last_x_ = result_.solution.x;
  }
}

std::vector<std::pair<std::string, double>> Kernel::task_errors() const {
  std::vector<std::pair<std::string, double>> errors;
  for (const auto& level : stack_)
    for (const auto& [name, task] : level.tasks)
      if (task->error.size()) errors.emplace_back(name, task->error.norm());
  return errors;
}

std::pair<Eigen::MatrixXd, Eigen::VectorXd> Kernel::rows(const std::string& name) {
  check_references();
  if (auto task = tasks_.find(name); task != tasks_.end()) {
    task->second->compute(robot_, refs_);
    return {task->second->A, task->second->b};
  }
  if (auto c = constraints_.find(name); c != constraints_.end()) {
    c->second->compute(robot_, refs_);
    return {c->second->C, c->second->d};
  }
  throw UnknownName("the native kernel has no task or constraint '" + name + "'");
}

}  // namespace lab
