// Centre-of-mass tasks (lab/controller/tasks/com.py): com, its horizontal rows com_xy, and on
// two point feet its horizontal parts along and across the foot line (Kim 2016 Fig. 6c):
// com_along_feet, com_across_feet.
#include "tasks/base.hpp"

namespace lab {
namespace {

/// CoM acceleration J_com q̈ + J̇_com v = kp (c_ref − c) + kd (ċ_ref − ċ).
class ComTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    const Eigen::Vector3d e = refs.com - robot.com;
    const Eigen::Vector3d de = refs.com_velocity - robot.com_velocity;
    reset(robot, 3);
    A.leftCols(robot.nv) = robot.Jcom;
    error = e;
    b = gains.kp * e + gains.kd * de - robot.com_drift;
  }
};

/// The horizontal CoM alone (Table 6, P3): the first two rows of `com`.
class ComXYTask : public Task {
 public:
  void compute(const RobotModel& robot, const References& refs) override {
    com_.gains = gains;
    com_.compute(robot, refs);
    A = com_.A.topRows<2>();
    b = com_.b.head<2>();
    error = com_.error.head<2>();
  }

 private:
  ComTask com_;
};

/// The horizontal unit vector (world) from the first to the second point foot in support (com.py
/// foot_line); false with fewer than two point feet in support, or two over each other.
bool foot_line(const RobotModel& robot, const References& refs, Eigen::Vector3d& line) {
  std::size_t feet[2], n = 0;
  for (std::size_t i = 0; i < robot.contacts.size() && n < 2; ++i)
    if (refs.contact_active[i] && robot.contacts[i].kind == ContactKind::point) feet[n++] = i;
  if (n < 2) return false;
  line = robot.contact_positions[feet[1]] - robot.contact_positions[feet[0]];
  line[2] = 0.0;
  const double length = line.norm();
  if (!(length > 1e-6)) return false;
  line /= length;
  return true;
}

/// The CoM's horizontal position along (or across) the line between two point feet in support,
/// one row: the `com` rows' component along that direction; no rows with fewer than two point
/// feet in support.
class ComFootLineTask : public Task {
 public:
  explicit ComFootLineTask(bool across) : across_(across) {}

  void compute(const RobotModel& robot, const References& refs) override {
    Eigen::Vector3d line;
    if (!foot_line(robot, refs, line)) {
      reset(robot, 0);
      error.resize(0);
      return;
    }
    // across: line × z (np.cross(line, Z))
    const Eigen::Vector3d direction =
        across_ ? Eigen::Vector3d(line[1], -line[0], 0.0) : Eigen::Vector3d(line);
    com_.gains = gains;
    com_.compute(robot, refs);
    A = direction.transpose() * com_.A;
    b.resize(1);
    b[0] = direction.dot(com_.b);
    error.resize(1);
    error[0] = direction.dot(com_.error);
  }

 private:
  bool across_;
  ComTask com_;
};

}  // namespace

void add_com_tasks(TaskRegistry& tasks) {
  tasks["com"] = std::make_unique<ComTask>();
  tasks["com_xy"] = std::make_unique<ComXYTask>();
  tasks["com_along_feet"] = std::make_unique<ComFootLineTask>(false);
  tasks["com_across_feet"] = std::make_unique<ComFootLineTask>(true);
}

}  // namespace lab
