// The one interface of every native behaviour (mirrors lab/controller/behaviours/base.py's
// Behaviour protocol's `update`): from the sim time, the robot model as the kernel's model update
// left it, the velocity command and the measured foot contacts, advance the behaviour's state and
// write its references (cpp/references.hpp, the one layout both sides share). A native server
// tick holds a `NativeBehaviour` and calls `update` between the model update and the solve; the
// Python bindings (behaviours/binding.hpp) call it on a Python behaviour's native tick.
#pragma once

#include <Eigen/Dense>

#include "behaviours/leg_posture.hpp"
#include "references.hpp"

namespace lab {

using RowMatrix3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;

/// What a behaviour's tick reads of the robot model: the arrays the native kernel's model update
/// fills (RobotModel.arrays(); world axes, base velocities in the base frame as in v), and the
/// robot's constants.
struct BehaviourModel {
  Eigen::Map<const Eigen::VectorXd> q, v;
  Eigen::Map<const RowMatrix3> base_rotation;
  Eigen::Map<const RowMatrixX3> contact_positions;  // n x 3
  Eigen::Map<const RowMatrixX3> contact_rotations;  // 3n x 3
  Eigen::Map<const RowMatrixX> contact_jacobian;    // nf x nv: J_c (point feet: 3 rows each)
  Eigen::Map<const Eigen::Vector3d> com, com_velocity;
  Eigen::Map<const RowMatrixX> centroidal_map;  // 6 x nv, A_G (Herzog eq. 19)
  double mass;                                  // kg
  Eigen::Vector3d gravity;                      // m/s², world

  /// [linear; angular] momentum about the CoM, world axes: h_G = A_G v (Herzog eq. 19).
  Eigen::Matrix<double, 6, 1> centroidal_momentum() const { return centroidal_map * v; }
};

/// The start time of a scripted behaviour (Python: `start`, None before the first tick).
struct MotionClock {
  bool started = false;
  double start = 0.0;  // s
  /// The time since the first tick (s), starting the clock at `t` on the first.
  double since(double t) {
    if (!started) start = t;
    started = true;
    return t - start;
  }
};

/// A behaviour's native tick. `command` is [vx (m/s), vy (m/s), yaw_rate (rad/s)] in the
/// heading frame, `touching` one flag per contact; `refs` holds the references the behaviour
/// owns (sized for the robot as its Python twin's) and is written in place.
class NativeBehaviour {
 public:
  virtual ~NativeBehaviour() = default;
  virtual void update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
                      const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) = 0;
};

}  // namespace lab
