// Python bindings of the state estimator: lab/world/estimator.py drives it on Python ticks and
// hands it to the native tick; tests/estimation/test_ekf_native.py reads its state.
#include "estimation/python.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <pinocchio/multibody/model.hpp>

#include "estimation/estimator.hpp"
#include "model.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace lab {
namespace {

using estimation::BaseEstimator;
using Vector = Eigen::Ref<const Eigen::VectorXd>;

template <typename T>
T knob(const nb::dict& values, const char* name) {
  if (!values.contains(name))
    throw nb::key_error((std::string("estimator: knob missing: ") + name).c_str());
  return nb::cast<T>(values[name]);
}

using InFlags = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

estimation::Flags flags(const InFlags& contacts) {
  return Eigen::Map<const estimation::Flags>(contacts.data(), contacts.shape(0));
}

}  // namespace

void bind_estimation(nb::module_& m) {
  nb::class_<BaseEstimator>(m, "EkfEstimator",
                            "lab/world/estimator.py's BaseEstimator under `ekf` in C++: the "
                            "accelerometer and the EKF (cpp/estimation)")
      .def(
          "__init__",
          [](BaseEstimator* self, const std::string& model, const std::vector<std::string>& frames,
             const Eigen::VectorXd& radii, const Eigen::Vector3d& gravity, double dt,
             const nb::dict& knobs) {
            const auto loaded = load_model(model);
            new (self) BaseEstimator(
                estimation::LeggedEkf(estimation::LegKinematics(*loaded, frames), radii, gravity,
                                      dt),
                realism::Accelerometer(knob<double>(knobs, "accel_noise"),
                                       knob<double>(knobs, "accel_bias_walk"),
                                       knob<int>(knobs, "measurement_delay"),
                                       knob<std::uint64_t>(knobs, "seed"), dt, gravity));
          },
          "model"_a, "frames"_a, "radii"_a, "gravity"_a, "dt"_a, "knobs"_a,
          "On pinocchio's serialized `model` (Model.saveToString()), the feet's `frames` and "
          "`radii` (m), `gravity` (m/s², world), the tick `dt` (s) and the realism knobs' values.")
      .def("reset", &BaseEstimator::reset, "q"_a, "v"_a)
      .def(
          "read",
          [](BaseEstimator& self, const Vector& q, const Vector& v, const Eigen::VectorXd& qm,
             const Eigen::VectorXd& vm, const InFlags& contacts) {
            Eigen::VectorXd qe = qm, ve = vm;
            self.read(q, v, qe, ve, flags(contacts));
            return std::make_tuple(qe, ve);
          },
          "q"_a, "v"_a, "qm"_a, "vm"_a, "contacts"_a,
          "The (q, v) the controller reads from the true (q, v), the measured (qm, vm) and the "
          "feet in contact.")
      .def_prop_ro("position", [](const BaseEstimator& s) { return s.filter().x().position; })
      .def_prop_ro("velocity", [](const BaseEstimator& s) { return s.filter().x().velocity; })
      .def_prop_ro("rotation", [](const BaseEstimator& s) { return s.filter().x().rotation; })
      .def_prop_ro(
          "feet",
          [](const BaseEstimator& s) { return Eigen::MatrixXd(s.filter().x().feet.transpose()); })
      .def_prop_ro("accel_bias", [](const BaseEstimator& s) { return s.filter().x().accel_bias; })
      .def_prop_ro("gyro_bias", [](const BaseEstimator& s) { return s.filter().x().gyro_bias; })
      .def_prop_ro("covariance", [](const BaseEstimator& s) { return s.filter().P(); })
      .def_prop_ro("since_touchdown",
                   [](const BaseEstimator& s) { return s.filter().since_touchdown(); });
}

}  // namespace lab
