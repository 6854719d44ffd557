// The centroidal momentum task of Herzog 2016 (lab/controller/tasks/momentum.py): momentum.
// K_h, the 6 × 9 feedback gain, is designed in Python (lab/controller/momentum.py: PD of eq. 22,
// LQR of eqs. 23–26 and its interpolation across a contact switch) and set here when it changes.
// Under LQR the gain depends on the contact configuration and the pose; the kernel holds the
// schedule's target while both stay (MomentumTask.to_kernel's rule, GainSchedule.held_arms),
// steps the interpolation to it across a contact switch itself (GainSchedule.gain's blend, the
// same arithmetic), and asks the Python schedule only on the other ticks: a switch, a redesign.
#include <functional>
#include <stdexcept>
#include <utility>

#include "tasks/registry.hpp"

namespace lab {
namespace {

/// A_G q̈ = ḣ_des − Ȧ_G v with ḣ_des = −K_h s + ḣ_ref (eqs. 20, 22, 24), s = [c − c_ref;
/// h_lin − m ċ_ref; h_ang] (world axes, about the CoM), ḣ_ref = [m c̈_ref; 0] fed forward; the
/// error is s.
class MomentumTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    if (schedule && !holds(robot, refs)) {
      const long blended = alone;  // the schedule catches up with the ticks blended here
      alone = 0;
      blend_length = 0;
      schedule(blended);  // it sets K_h (and holds it, with its blend, if the target stays)
    } else if (blend_step < blend_length) {
      step_blend();
    }
    if (!gain_set) throw std::logic_error("momentum: no K_h was set (Kernel.set_momentum_gain)");
    const Eigen::Matrix<double, 6, 1> h = robot.centroidal_map * robot.v;
    reset(robot, 6);
    A.leftCols(robot.nv) = robot.centroidal_map;
    error.resize(9);
    error << robot.com - refs.com, h.head<3>() - robot.mass * refs.com_velocity, h.tail<3>();
    b.noalias() = -gain * error;
    b -= robot.centroidal_drift();
    b.head<3>() += robot.mass * refs.com_acceleration;
  }

  /// Whether the held K_h stays this tick: it was held as settled for this contact
  /// configuration, and no arm p_i − c of a contact in support has moved more than the
  /// tolerance from the pose its design read (GainSchedule.settled, momentum.py).
  bool holds(const RobotModel& robot, const References& refs) const {
    if (!held || refs.contact_active.size() != held_active.size() ||
        (refs.contact_active != held_active).any())
      return false;
    Eigen::Index row = 0;
    for (Eigen::Index i = 0; i < held_active.size(); ++i) {
      if (!held_active(i)) continue;
      const Eigen::Vector3d arm = robot.contact_positions[static_cast<std::size_t>(i)] - robot.com;
      if ((arm - held_arms.row(row++).transpose()).cwiseAbs().maxCoeff() > arm_tolerance)
        return false;
    }
    return true;
  }

  /// One tick of the interpolation while held: GainSchedule.gain's step, K_h = (1 − α) K_from
  /// + α K_to with α = step / length, the target itself at the last step.
  void step_blend() {
    ++blend_step;
    ++alone;
    if (blend_step == blend_length) {
      gain = blend_to;
    } else {
      const double alpha = static_cast<double>(blend_step) / static_cast<double>(blend_length);
      gain = (1.0 - alpha) * blend_from + alpha * blend_to;
    }
  }

  Eigen::Matrix<double, 6, 9> gain = Eigen::Matrix<double, 6, 9>::Zero();
  bool gain_set = false;
  // the Python schedule's tick, told how many blend steps were made here since it was last asked
  // (empty: K_h is set from outside)
  std::function<void(long)> schedule;
  Eigen::Matrix<double, 6, 9> blend_from = Eigen::Matrix<double, 6, 9>::Zero();
  Eigen::Matrix<double, 6, 9> blend_to = Eigen::Matrix<double, 6, 9>::Zero();
  long blend_step = 0, blend_length = 0;  // no blend while step >= length
  long alone = 0;                         // blend steps made since the schedule was last asked
  double arm_tolerance = 0.0;             // m (momentum.py ARM_TOLERANCE)
  bool held = false;                      // K_h is settled for held_active at held_arms
  Eigen::Array<bool, Eigen::Dynamic, 1> held_active;
  Eigen::MatrixXd held_arms;  // (contacts in support) × 3, the pose the design read
};

}  // namespace

void set_momentum_gain(Task& momentum, const Eigen::Ref<const Eigen::MatrixXd>& gain) {
  if (gain.rows() != 6 || gain.cols() != 9)
    throw std::invalid_argument("momentum: K_h needs 6 x 9 entries, got " +
                                std::to_string(gain.rows()) + " x " + std::to_string(gain.cols()));
  if (!gain.allFinite()) throw std::invalid_argument("momentum: K_h has non-finite entries");
  auto& task = dynamic_cast<MomentumTask&>(momentum);
  task.gain = gain;
  task.gain_set = true;
}

void set_momentum_schedule(Task& momentum, std::function<void(long)> schedule,
                           double arm_tolerance) {
  if (!(arm_tolerance >= 0.0))
    throw std::invalid_argument("momentum: the arm tolerance must be a number >= 0");
  auto& task = dynamic_cast<MomentumTask&>(momentum);
  task.schedule = std::move(schedule);
  task.arm_tolerance = arm_tolerance;
  task.held = false;
  task.blend_length = task.alone = 0;
}

void hold_momentum_gain(Task& momentum, const Eigen::Ref<const Eigen::Array<bool, -1, 1>>& active,
                        const Eigen::Ref<const Eigen::MatrixXd>& arms) {
  if (arms.cols() != 3 || arms.rows() != active.count() || !arms.allFinite())
    throw std::invalid_argument(
        "momentum: the held arms need 3 finite columns, one row per contact in support");
  auto& task = dynamic_cast<MomentumTask&>(momentum);
  task.held_active = active;
  task.held_arms = arms;
  task.held = true;
}

void blend_momentum_gain(Task& momentum, const Eigen::Ref<const Eigen::MatrixXd>& from,
                         const Eigen::Ref<const Eigen::MatrixXd>& to, long step, long length) {
  if (from.rows() != 6 || from.cols() != 9 || to.rows() != 6 || to.cols() != 9 ||
      !from.allFinite() || !to.allFinite())
    throw std::invalid_argument("momentum: a blend's gains need 6 x 9 finite entries");
  if (!(0 <= step && step <= length))
    throw std::invalid_argument("momentum: a blend's step must be within 0 ... its length");
  auto& task = dynamic_cast<MomentumTask&>(momentum);
  task.blend_from = from;
  task.blend_to = to;
  task.blend_step = step;
  task.blend_length = length;
}

long take_momentum_blend_steps(Task& momentum) {
  auto& task = dynamic_cast<MomentumTask&>(momentum);
  return std::exchange(task.alone, 0);
}

void release_momentum_gain(Task& momentum) { dynamic_cast<MomentumTask&>(momentum).held = false; }

void add_momentum_tasks(TaskRegistry& tasks) {
  tasks["momentum"] = std::make_unique<MomentumTask>();
}

}  // namespace lab
