// Python bindings of the behaviours' hot parts: LegPostureReference calls them on native ticks.
#include "behaviours/python.hpp"

#include <nanobind/ndarray.h>

#include "behaviours/leg_posture.hpp"

namespace nb = nanobind;

namespace lab {
namespace {

template <long... Shape>
using Array = nb::ndarray<const double, nb::shape<Shape...>, nb::c_contig, nb::device::cpu>;
using Out = nb::ndarray<double, nb::c_contig, nb::device::cpu>;

void leg_posture_velocity_py(Array<-1, 3> contact_positions, Array<-1, 3, 3> contact_rotations,
                             Out previous_rotations, Array<-1, -1> contact_jacobian,
                             Array<-1> radius,
                             nb::ndarray<const bool, nb::shape<-1>, nb::c_contig> stance,
                             Array<-1, 3> foot_position, Array<-1, 3> foot_velocity,
                             Array<3> base_position, Array<3> base_velocity,
                             Array<3> base_angular_velocity, double height_error, double dt,
                             double damping, Out velocity) {
  const auto n = static_cast<Eigen::Index>(contact_positions.shape(0));
  const auto nv = static_cast<Eigen::Index>(contact_jacobian.shape(1));
  if (contact_rotations.shape(0) != static_cast<size_t>(n) ||
      previous_rotations.size() != static_cast<size_t>(9 * n) ||
      contact_jacobian.shape(0) != static_cast<size_t>(3 * n) || radius.shape(0) != n ||
      stance.shape(0) != n || foot_position.shape(0) != n || foot_velocity.shape(0) != n ||
      nv < 6 || velocity.size() != static_cast<size_t>(nv - 6))
    throw nb::value_error(
        "leg_posture_velocity: n feet need n x 3 positions, n x 3 x 3 rotations (now and last "
        "tick), a 3n x nv Jacobian, n radii and stance flags, n x 3 swing references and nv - 6 "
        "joint velocities");
  const LegPostureInput in{Eigen::Map<const RowMatrixX3>(contact_positions.data(), n, 3),
                           Eigen::Map<const RowMatrixX3>(contact_rotations.data(), 3 * n, 3),
                           Eigen::Map<const RowMatrixX>(contact_jacobian.data(), 3 * n, nv),
                           Eigen::Map<const Eigen::VectorXd>(radius.data(), n),
                           stance.data(),
                           Eigen::Map<const RowMatrixX3>(foot_position.data(), n, 3),
                           Eigen::Map<const RowMatrixX3>(foot_velocity.data(), n, 3),
                           Eigen::Map<const Eigen::Vector3d>(base_position.data()),
                           Eigen::Map<const Eigen::Vector3d>(base_velocity.data()),
                           Eigen::Map<const Eigen::Vector3d>(base_angular_velocity.data()),
                           height_error,
                           dt,
                           damping};
  leg_posture_velocity(in, Eigen::Map<RowMatrixX3>(previous_rotations.data(), 3 * n, 3),
                       Eigen::Map<Eigen::VectorXd>(velocity.data(), nv - 6));
}

}  // namespace

void bind_behaviours(nb::module_& m) {
  m.def("leg_posture_velocity", &leg_posture_velocity_py, nb::arg("contact_positions"),
        nb::arg("contact_rotations"), nb::arg("previous_rotations"), nb::arg("contact_jacobian"),
        nb::arg("radius"), nb::arg("stance"), nb::arg("foot_position"), nb::arg("foot_velocity"),
        nb::arg("base_position"), nb::arg("base_velocity"), nb::arg("base_angular_velocity"),
        nb::arg("height_error"), nb::arg("dt"), nb::arg("damping"), nb::arg("velocity"),
        "LegPostureReference.update's joint velocity references (leg_posture.py) into "
        "`velocity`; `previous_rotations` (the feet's orientations last tick) becomes this "
        "tick's.");
}

}  // namespace lab
