// Python bindings of the realism layer: the agreement test and the micro benchmark drive it
// with the knobs lab/realism/knobs.py checked (RealismKnobs.values()); and of the touch
// detector on the estimated contact forces (contact_estimate.hpp), which the session hands to
// the native tick.
#include "realism/python.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>

#include <algorithm>
#include <vector>

#include "controller.hpp"
#include "realism/contact_estimate.hpp"
#include "realism/layer.hpp"

namespace nb = nanobind;

namespace lab {
namespace {

using InFlags = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

/// A copy of `touch` as a numpy bool array.
nb::object touch_array(const std::vector<char>& touch) {
  auto* data = new bool[touch.size()];
  std::copy(touch.begin(), touch.end(), data);
  nb::capsule owner(data, [](void* p) noexcept { delete[] static_cast<bool*>(p); });
  return nb::cast(nb::ndarray<nb::numpy, bool, nb::ndim<1>>(data, {touch.size()}, owner));
}

template <typename T>
T knob(const nb::dict& values, const char* name) {
  if (!values.contains(name))
    throw nb::key_error((std::string("realism: knob missing: ") + name).c_str());
  return nb::cast<T>(values[name]);
}

realism::Knobs knobs_of(const nb::dict& v) {
  realism::Knobs k;
  k.gyro_noise = knob<double>(v, "gyro_noise");
  k.gyro_bias_walk = knob<double>(v, "gyro_bias_walk");
  k.attitude_noise = knob<double>(v, "attitude_noise");
  k.base_velocity_noise = knob<double>(v, "base_velocity_noise");
  k.base_position_noise = knob<double>(v, "base_position_noise");
  k.encoder_bits = knob<int>(v, "encoder_bits");
  k.encoder_noise = knob<double>(v, "encoder_noise");
  k.velocity_differencing = knob<int>(v, "velocity_differencing") != 0;
  k.velocity_filter_hz = knob<double>(v, "velocity_filter_hz");
  k.measurement_delay = knob<int>(v, "measurement_delay");
  k.command_delay = knob<int>(v, "command_delay");
  k.actuator = knob<std::string>(v, "actuator");
  k.torque_bandwidth_hz = knob<double>(v, "torque_bandwidth_hz");
  k.sea_stiffness = knob<double>(v, "sea_stiffness");
  k.sea_motor_inertia = knob<double>(v, "sea_motor_inertia");
  k.sea_kp = knob<double>(v, "sea_kp");
  k.sea_kd = knob<double>(v, "sea_kd");
  k.seed = knob<std::uint64_t>(v, "seed");
  return k;
}

}  // namespace

void bind_realism(nb::module_& m) {
  nb::class_<realism::Layer>(m, "RealismLayer",
                             "lab/realism/layer.py's RealismLayer in C++ (same seed, same draws)")
      .def(
          "__init__",
          [](realism::Layer* self, const nb::dict& knobs, int na, double dt) {
            new (self) realism::Layer(knobs_of(knobs), na, dt);
          },
          nb::arg("knobs"), nb::arg("na"), nb::arg("dt"))
      .def("reset", &realism::Layer::reset, nb::arg("q"), nb::arg("tau"))
      .def("measure", &realism::Layer::measure, nb::arg("q"), nb::arg("v"))
      .def("actuate", &realism::Layer::actuate, nb::arg("command"), nb::arg("q"), nb::arg("v"))
      .def_prop_ro("ideal", &realism::Layer::ideal)
      .def_prop_ro("tick", &realism::Layer::tick);
  nb::class_<realism::ContactEstimator>(
      m, "ContactEstimator",
      "lab/realism/contact_estimate.py's ContactEstimator in C++ (the same arithmetic); the "
      "native tick runs it once given (ServerTick.set_touch_estimator)")
      .def(
          "__init__",
          [](realism::ContactEstimator* self, double on, double off, double min_force,
             double accel_filter_hz, double dt, int n_joints, int n_feet) {
            new (self) realism::ContactEstimator({on, off, min_force, accel_filter_hz}, dt,
                                                 n_joints, n_feet);
          },
          nb::arg("on"), nb::arg("off"), nb::arg("min_force"), nb::arg("accel_filter_hz"),
          nb::arg("dt"), nb::arg("n_joints"), nb::arg("n_feet"))
      .def(
          "update",
          [](realism::ContactEstimator& self, const Kernel& kernel, const Eigen::VectorXd& applied,
             const Eigen::VectorXd& vj, const InFlags& flags) {
            const RobotModel& robot = kernel.robot();
            if (applied.size() != robot.na || vj.size() != robot.na ||
                flags.shape(0) != robot.contacts.size() || self.n_joints() != robot.na ||
                self.n_feet() != static_cast<int>(robot.contacts.size()))
              throw std::invalid_argument(
                  "ContactEstimator.update: na torques and velocities, one flag per foot, of "
                  "the estimator's robot");
            std::vector<char> raw(flags.data(), flags.data() + flags.shape(0));
            return touch_array(self.update(robot, applied, vj, raw.data()));
          },
          nb::arg("kernel"), nb::arg("applied"), nb::arg("joint_velocities"), nb::arg("flags"),
          "This tick's touch flags (a bool array) at the kernel's model (its last update), from "
          "last tick's applied torques (N m) and the measured joint velocities (rad/s); a foot "
          "it cannot estimate keeps its `flags`.")
      .def(
          "take_state",
          [](realism::ContactEstimator& self, std::optional<Eigen::VectorXd> velocity,
             const Eigen::VectorXd& accelerations, const InFlags& touch) {
            self.take_state(velocity ? &*velocity : nullptr, accelerations,
                            std::vector<char>(touch.data(), touch.data() + touch.shape(0)));
          },
          nb::arg("velocity").none(), nb::arg("accelerations"), nb::arg("touch"),
          "Continue from another estimator's state (velocity None: not started).")
      .def_prop_ro("velocity",
                   [](const realism::ContactEstimator& self) -> std::optional<Eigen::VectorXd> {
                     if (!self.started()) return std::nullopt;
                     return self.velocity();
                   })
      .def_prop_ro("touch",
                   [](const realism::ContactEstimator& self) { return touch_array(self.touch()); })
      .def_prop_ro("normal", &realism::ContactEstimator::normal)
      .def_prop_ro("accelerations", &realism::ContactEstimator::accelerations);
}

}  // namespace lab
