// Python bindings of the behaviours' hot parts: LegPostureReference and Walking call them on
// native ticks.
#include "behaviours/python.hpp"

#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <string>
#include <vector>

#include "behaviours/leg_posture.hpp"
#include "behaviours/walking.hpp"

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

// ------------------------------------------------------------------------------- Walking
using Doubles = nb::ndarray<double, nb::c_contig, nb::device::cpu>;
using Flags = nb::ndarray<bool, nb::c_contig, nb::device::cpu>;

/// `owner.name` as a C-contiguous array of `size` entries (taken in place, never copied);
/// raises ValueError naming the field otherwise.
template <typename Array>
Array field(nb::handle owner, const char* name, std::size_t size) {
  Array array;
  if (!nb::try_cast(owner.attr(name), array, false) || array.size() != size)
    throw nb::value_error((std::string("native walking: ") + name + " must be a C-contiguous " +
                           "array of " + std::to_string(size) + " entries of its type")
                              .c_str());
  return array;
}

Eigen::Map<Eigen::VectorXd> vector(Doubles& a) {
  return {a.data(), static_cast<Eigen::Index>(a.size())};
}
Eigen::Map<RowMatrixX3> rows3(Doubles& a, std::size_t offset = 0, Eigen::Index n = -1) {
  return {a.data() + offset, n < 0 ? static_cast<Eigen::Index>(a.size() / 3) : n, 3};
}

/// The native tick of a Python `Walking` (walking.py): `update` loads the Python object's state
/// when told it changed (or on a new robot model), runs lab::Walking::update on the model's and
/// the references' arrays in place, and writes the scalar state back to the Python objects, so
/// that the Python Walking stays current and can run the next tick itself.
class WalkingBinding {
 public:
  void update(nb::handle walking, nb::handle robot, double t,
              nb::ndarray<const double, nb::shape<3>, nb::c_contig, nb::device::cpu> command,
              nb::ndarray<const bool, nb::shape<-1>, nb::c_contig, nb::device::cpu> touching,
              bool reload) {
    if (reload || !robot.is(robot_)) load(walking, robot);
    const std::size_t n = core_.scheduler.legs.size();
    if (touching.shape(0) != n)
      throw nb::value_error("native walking: `touching` needs one flag per foot");
    before_ = core_.scheduler.legs;
    const Eigen::Index nv = static_cast<Eigen::Index>(v_.size());
    const Eigen::Index nq = static_cast<Eigen::Index>(q_.size());
    const WalkingModel model{Eigen::Map<const Eigen::VectorXd>(q_.data(), nq),
                             Eigen::Map<const Eigen::VectorXd>(v_.data(), nv),
                             Eigen::Map<const RowMatrix3>(model_rotation_.data()),
                             Eigen::Map<const RowMatrixX3>(contact_positions_.data(), n, 3),
                             Eigen::Map<const RowMatrixX3>(contact_rotations_.data(), 3 * n, 3),
                             Eigen::Map<const RowMatrixX>(jacobian_.data(), 3 * n, nv)};
    const Eigen::Index plane = static_cast<Eigen::Index>(3 * n);
    WalkingReferences refs{contact_active_.data(),
                           vector(posture_weight_),
                           vector(normal_force_max_),
                           rows3(foot_references_, 0, n),
                           rows3(foot_references_, plane, n),
                           rows3(foot_references_, 2 * plane, n),
                           Eigen::Map<RowMatrix3>(base_rotation_.data()),
                           Eigen::Map<Eigen::Vector3d>(base_angular_velocity_.data()),
                           Eigen::Map<Eigen::Vector3d>(base_linear_velocity_.data()),
                           Eigen::Map<Eigen::Vector3d>(com_.data()),
                           Eigen::Map<Eigen::Vector3d>(com_velocity_.data()),
                           base_height_};
    LegPostureState posture{
        vector(position_),
        vector(velocity_),
        rows3(rotations_),
        Eigen::Map<const Eigen::VectorXd>(radius_.data(), static_cast<Eigen::Index>(n)),
        &joints_,
        damping_};
    core_.update(t, model, command.data(), touching.data(), refs, posture);
    base_height_ = refs.base_height;
    write_back(walking);
  }

 private:
  void load(nb::handle walking, nb::handle robot) {
    nb::object scheduler = walking.attr("scheduler");
    nb::object refs = walking.attr("references"), posture = walking.attr("posture");
    nb::list legs(scheduler.attr("legs"));
    const std::size_t n = nb::len(legs);
    if (n == 0 || n > static_cast<std::size_t>(kMaxLegs))
      throw nb::value_error("native walking: needs 1 to 8 legs");
    const std::size_t nq = nb::len(nb::object(robot.attr("q")));
    const std::size_t nv = nb::len(nb::object(robot.attr("v")));
    q_ = field<Doubles>(robot, "q", nq);
    v_ = field<Doubles>(robot, "v", nv);
    model_rotation_ = field<Doubles>(robot, "base_rotation", 9);
    contact_positions_ = field<Doubles>(robot, "contact_positions", 3 * n);
    contact_rotations_ = field<Doubles>(robot, "contact_rotations", 9 * n);
    jacobian_ = field<Doubles>(robot, "Jc", 3 * n * nv);  // point feet: 3 rows each
    const std::size_t na = nv - 6;
    contact_active_ = field<Flags>(refs, "contact_active", n);
    posture_weight_ = field<Doubles>(refs, "posture_weight", n);
    normal_force_max_ = field<Doubles>(refs, "normal_force_max", n);
    foot_references_ = field<Doubles>(walking, "foot_references", 9 * n);
    base_angular_velocity_ = field<Doubles>(refs, "base_angular_velocity", 3);
    base_linear_velocity_ = field<Doubles>(refs, "base_linear_velocity", 3);
    com_ = field<Doubles>(refs, "com", 3);
    com_velocity_ = field<Doubles>(refs, "com_velocity", 3);
    base_height_ = nb::cast<double>(refs.attr("base_height"));
    position_ = field<Doubles>(posture, "position", na);
    velocity_ = field<Doubles>(posture, "velocity", na);
    rotations_ = field<Doubles>(posture, "_rotations", 9 * n);
    radius_ = field<Doubles>(posture, "_radius", n);
    damping_ = nb::cast<double>(
        nb::module_::import_("lab.controller.behaviours.leg_posture").attr("DAMPING"));
    joints_.clear();
    for (nb::handle leg_joints : nb::list(posture.attr("joints")))
      joints_.push_back(nb::cast<std::vector<int>>(leg_joints.attr("tolist")()));
    if (joints_.size() != n) throw nb::value_error("native walking: one joint list per leg");
    for (const auto& leg_joints : joints_)
      for (int j : leg_joints)
        if (j < 0 || static_cast<std::size_t>(j) >= na)
          throw nb::value_error("native walking: a leg joint is out of range");
    liftoff_ = field<Doubles>(walking, "liftoff", 3 * n);

    Walking& w = core_;
    w.hips.clear();
    for (nb::handle hip : nb::list(walking.attr("hips")))
      w.hips.emplace_back(nb::cast<double>(hip[0]), nb::cast<double>(hip[1]));
    w.height = nb::cast<double>(walking.attr("height"));
    Doubles com_offset = field<Doubles>(walking, "com_offset", 3);
    w.com_offset = Eigen::Map<Eigen::Vector3d>(com_offset.data());
    w.full_load = nb::cast<double>(walking.attr("full_load"));
    w.cycle_time = nb::cast<double>(walking.attr("cycle_time"));
    w.step_height = nb::cast<double>(walking.attr("step_height"));
    const std::string planner = nb::cast<std::string>(walking.attr("footholds"));
    if (planner == "robocentric") {
      w.footholds = FootholdPlanner::kRobocentric;
    } else if (planner == "raibert") {
      w.footholds = FootholdPlanner::kRaibert;
    } else {
      throw nb::value_error(("native walking: no foothold planner " + planner).c_str());
    }
    w.t = nb::cast<double>(walking.attr("t"));
    w.yaw_ref = nb::cast<double>(walking.attr("yaw_ref"));
    for (int k = 0; k < 3; ++k) {
      w.command(k) = nb::cast<double>(walking.attr("command")[k]);
      w.measured_twist(k) = nb::cast<double>(walking.attr("measured_twist")[k]);
    }
    w.liftoff = rows3(liftoff_);

    GaitScheduler& s = w.scheduler;
    nb::object gait = scheduler.attr("gait");
    s.duty_factor = nb::cast<double>(gait.attr("duty_factor"));
    s.cycle_time = nb::cast<double>(scheduler.attr("cycle_time"));
    s.phase = nb::cast<double>(scheduler.attr("phase"));
    s.t = nb::cast<double>(scheduler.attr("t"));
    nb::object states = nb::module_::import_("lab.controller.behaviours.gait").attr("LegState");
    stance_state_ = states.attr("STANCE");
    swing_state_ = states.attr("SWING");
    reaching_state_ = states.attr("REACHING");
    s.legs.assign(n, Leg{});
    legs_.clear();
    for (std::size_t i = 0; i < n; ++i) {
      nb::object py_leg = legs[i];
      Leg& leg = s.legs[i];
      nb::object role = py_leg.attr("role");
      leg.offset = nb::cast<double>(gait.attr("offsets")[role]);
      nb::object state = py_leg.attr("state");
      leg.state = state.is(stance_state_)  ? LegState::kStance
                  : state.is(swing_state_) ? LegState::kSwing
                                           : LegState::kReaching;
      leg.since = nb::cast<double>(py_leg.attr("since"));
      leg.swing_duration = nb::cast<double>(py_leg.attr("swing_duration"));
      nb::object unload_start = py_leg.attr("unload_start");
      leg.unloading = !unload_start.is_none();
      leg.unload_start = leg.unloading ? nb::cast<double>(unload_start) : 0.0;
      leg.last_cycle = nb::cast<long>(py_leg.attr("last_cycle"));
      legs_.push_back(py_leg);
    }
    // The references' base rotation becomes an array this binding writes in place (a Python
    // tick replaces it with pinocchio's, which need not be C-contiguous).
    refs.attr("base_rotation") = nb::module_::import_("numpy").attr("eye")(3);
    base_rotation_ = field<Doubles>(refs, "base_rotation", 9);
    scheduler_ = scheduler;
    refs_ = refs;
    robot_ = nb::borrow(robot);
  }

  /// The scalar state into the Python objects; a leg's fields only when they changed.
  void write_back(nb::handle walking) {
    const Walking& w = core_;
    walking.attr("t") = w.t;
    walking.attr("command") = nb::make_tuple(w.command(0), w.command(1), w.command(2));
    walking.attr("yaw_ref") = w.yaw_ref;
    walking.attr("measured_twist") =
        nb::make_tuple(w.measured_twist(0), w.measured_twist(1), w.measured_twist(2));
    rows3(liftoff_) = w.liftoff;
    scheduler_.attr("phase") = w.scheduler.phase;
    scheduler_.attr("t") = w.scheduler.t;
    refs_.attr("base_height") = base_height_;
    for (std::size_t i = 0; i < legs_.size(); ++i) {
      const Leg &now = w.scheduler.legs[i], &then = before_[i];
      if (now.state == then.state && now.since == then.since &&
          now.swing_duration == then.swing_duration && now.unloading == then.unloading &&
          now.unload_start == then.unload_start && now.last_cycle == then.last_cycle)
        continue;
      nb::handle leg = legs_[i];
      leg.attr("state") = now.state == LegState::kStance  ? stance_state_
                          : now.state == LegState::kSwing ? swing_state_
                                                          : reaching_state_;
      leg.attr("since") = now.since;
      leg.attr("swing_duration") = now.swing_duration;
      leg.attr("unload_start") = now.unloading ? nb::cast(now.unload_start) : nb::none();
      leg.attr("last_cycle") = now.last_cycle;
    }
  }

  Walking core_;
  std::vector<Leg> before_;  // the legs before this tick
  nb::object robot_, scheduler_, refs_;
  std::vector<nb::object> legs_;
  nb::object stance_state_, swing_state_, reaching_state_;
  Doubles q_, v_, model_rotation_, contact_positions_, contact_rotations_, jacobian_;
  Flags contact_active_;
  Doubles posture_weight_, normal_force_max_, foot_references_, base_rotation_,
      base_angular_velocity_, base_linear_velocity_, com_, com_velocity_;
  Doubles position_, velocity_, rotations_, radius_, liftoff_;
  std::vector<std::vector<int>> joints_;
  double base_height_ = 0.0, damping_ = 0.0;
};

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
  nb::class_<WalkingBinding>(m, "Walking",
                             "The native tick of a Python Walking (walking.py), in one call.")
      .def(nb::init<>())
      .def("update", &WalkingBinding::update, nb::arg("walking"), nb::arg("robot"), nb::arg("t"),
           nb::arg("command"), nb::arg("touching"), nb::arg("reload"),
           "Walking.update's steps in C++ (cpp/behaviours/walking.cpp) on the model's and the "
           "references' arrays in place; `reload`: the Python object's state changed since the "
           "last call (a Python tick, configure, continue_from) and is read first. The walking "
           "state is written back to the Python objects.");
}

}  // namespace lab
