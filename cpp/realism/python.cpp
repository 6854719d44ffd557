// Python bindings of the realism layer: the agreement test and the micro benchmark drive it
// with the knobs lab/realism/knobs.py checked (RealismKnobs.values()).
#include "realism/python.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>

#include "realism/layer.hpp"

namespace nb = nanobind;

namespace lab {
namespace {

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
}

}  // namespace lab
