// The swing-foot task (lab/controller/tasks/feet.py, Hutter 2014 §5.1): swing_feet.
#include "tasks/feet.hpp"

namespace lab {

Eigen::Array<bool, Eigen::Dynamic, 1> swinging(
    const RobotModel& robot, const Eigen::Array<bool, Eigen::Dynamic, 1>& active) {
  Eigen::Array<bool, Eigen::Dynamic, 1> out(active.size());
  for (Eigen::Index i = 0; i < active.size(); ++i)
    out[i] = robot.contacts[i].kind == ContactKind::point && !active[i];
  return out;
}

bool has_swing(const References& refs) { return refs.foot_position.size() > 0; }

void tracked(const RobotModel& robot, const References& refs,
             Eigen::Array<bool, Eigen::Dynamic, 1>& out) {
  const auto& active = refs.contact_active;
  const bool named = refs.swing_tracked.size() == active.size();
  out.resize(active.size());
  for (Eigen::Index i = 0; i < active.size(); ++i)
    out[i] = robot.contacts[i].kind == ContactKind::point &&
             (named ? refs.swing_tracked[i] : !active[i]);
}

namespace {

/// Each point foot out of support tracks its swing trajectory, world axes:
/// J_i q̈ + J̇_i v = a_ref + kp (p_ref − p) + kd (v_ref − v).
class SwingFeetTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    Eigen::Index n = 0;
    if (has_swing(refs)) {
      tracked(robot, refs, feet_);
      contact_rows(robot, feet_, index_);
      n = static_cast<Eigen::Index>(index_.size());
    }
    const auto& index = index_;
    const auto& feet = feet_;
    reset(robot, n);
    error.resize(n);
    if (n == 0) return;
    write_jacobian_rows(robot, index, A);
    velocity_.noalias() = A.leftCols(robot.nv) * robot.v;
    const Eigen::VectorXd& velocity = velocity_;
    Eigen::Index row = 0;
    for (Eigen::Index i = 0; i < feet.size(); ++i) {
      if (!feet[i]) continue;
      for (int k = 0; k < 3; ++k, ++row) {
        const Eigen::Index c = 3 * i + k;
        const double e = refs.foot_position[c] - robot.contact_positions[i][k];
        const double de = refs.foot_velocity[c] - velocity[row];
        error[row] = e;
        b[row] =
            refs.foot_acceleration[c] + gains.kp * e + gains.kd * de - robot.Jc_dot_v[index[row]];
      }
    }
  }

 private:
  Eigen::Array<bool, Eigen::Dynamic, 1> feet_;  // swinging point feet
  std::vector<Eigen::Index> index_;             // their rows of Jc
  Eigen::VectorXd velocity_;                    // their velocities J v
};

}  // namespace

void add_feet_tasks(TaskRegistry& tasks) {
  tasks["swing_feet"] = std::make_unique<SwingFeetTask>();
}

}  // namespace lab
