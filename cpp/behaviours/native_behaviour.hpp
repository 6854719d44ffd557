// lab::NativeBehaviour: the one interface through which the server's native tick
// (cpp/server_tick.cpp) runs a behaviour's tick. Each native behaviour binding
// (behaviours/python.cpp: Walking, BipedStepping; the twins of the other behaviours likewise)
// derives from it; its Python behaviour declares it with `NativeTicking`
// (lab/controller/behaviours/base.py).
#pragma once

#include <nanobind/nanobind.h>

#include <cstddef>

namespace lab {

class NativeBehaviour {
 public:
  virtual ~NativeBehaviour() = default;
  /// One tick of the Python behaviour `owner` at sim time `t` (s) on the Python RobotModel
  /// `robot` (its arrays filled by this tick's model update): `command` [vx, vy, yaw_rate] (3),
  /// `touching` one flag per foot (`feet` of them); `reload`: the owner's state changed since the
  /// last tick here and is read first. Writes the references in place and the state back into
  /// `owner`; throws (ValueError) naming what does not fit.
  virtual void tick(nanobind::handle owner, nanobind::handle robot, double t, const double* command,
                    const bool* touching, std::size_t feet, bool reload) = 0;
};

}  // namespace lab
