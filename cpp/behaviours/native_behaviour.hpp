// lab::TickedBehaviour: the one interface through which the server's native tick
// (cpp/plant/server_tick.cpp) runs a Python behaviour's native twin. Every twin's binding
// (behaviours/binding.hpp's Binding<Core>, bound as _kernel.Walking, BipedStepping, Balance, ...)
// derives from it; its Python behaviour declares the twin with `NativeTwin`
// (lab/controller/behaviours/native.py). The twin itself is a lab::NativeBehaviour
// (behaviours/behaviour.hpp).
#pragma once

#include <nanobind/nanobind.h>

#include <cstddef>

namespace lab {

class TickedBehaviour {
 public:
  virtual ~TickedBehaviour() = default;
  /// One tick of the Python behaviour `owner` at sim time `t` (s) on the Python RobotModel
  /// `robot` (its arrays filled by this tick's model update): `command` [vx, vy, yaw_rate] (3),
  /// `touching` one flag per foot (`feet` of them); `reload`: the owner's state changed since the
  /// last tick here and is read first. Writes the references in place and the state back into
  /// `owner`; throws (ValueError) naming what does not fit.
  virtual void tick(nanobind::handle owner, nanobind::handle robot, double t, const double* command,
                    const bool* touching, std::size_t feet, bool reload) = 0;
};

}  // namespace lab
