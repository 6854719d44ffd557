// Python bindings of the behaviours' hot parts: LegPostureReference's velocity, and the walking
// and stepping twins' state load and write-back for binding.hpp's Binding (Walking and
// BipedStepping call them on native ticks); the standing behaviours' are python_standing.cpp's.
#include "behaviours/python.hpp"

#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <string>
#include <utility>
#include <vector>

#include "behaviours/binding.hpp"
#include "behaviours/biped_step.hpp"
#include "behaviours/leg_posture.hpp"
#include "behaviours/native_behaviour.hpp"
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

}  // namespace

// ------------------------------------------------------------------------------- Walking
using binding::Doubles;
using binding::field;

namespace {

/// `owner.name` as an n x 3 row-major map of a C-contiguous float64 array of 3n entries.
RowMatrixX3 rows3(nb::handle owner, const char* name, std::size_t n, const std::string& who) {
  Doubles a = field<Doubles>(owner, name, 3 * n, who);
  return Eigen::Map<const RowMatrixX3>(a.data(), static_cast<Eigen::Index>(n), 3);
}

nb::object leg_states() {
  return nb::module_::import_("lab.controller.behaviours.gait").attr("LegState");
}

}  // namespace

/// The Python `Walking`'s state (walking.py, its scheduler and leg posture) into the twin.
void load_state(WalkingBehaviour& b, nb::handle walking, const std::string& who) {
  nb::object scheduler = walking.attr("scheduler"), posture = walking.attr("posture");
  nb::list legs(scheduler.attr("legs"));
  const std::size_t n = nb::len(legs);
  if (n == 0 || n > static_cast<std::size_t>(kMaxLegs))
    throw nb::value_error("native walking: needs 1 to 8 legs");
  const std::size_t na = nb::len(nb::object(posture.attr("position")));
  b.previous_rotations = rows3(posture, "_rotations", 3 * n, who);
  Doubles radius = field<Doubles>(posture, "_radius", n, who);
  b.radius = Eigen::Map<const Eigen::VectorXd>(radius.data(), static_cast<Eigen::Index>(n));
  b.damping = nb::cast<double>(
      nb::module_::import_("lab.controller.behaviours.leg_posture").attr("DAMPING"));
  b.joints.clear();
  for (nb::handle leg_joints : nb::list(posture.attr("joints")))
    b.joints.push_back(nb::cast<std::vector<int>>(leg_joints.attr("tolist")()));
  if (b.joints.size() != n) throw nb::value_error("native walking: one joint list per leg");
  for (const auto& leg_joints : b.joints)
    for (int j : leg_joints)
      if (j < 0 || static_cast<std::size_t>(j) >= na)
        throw nb::value_error("native walking: a leg joint is out of range");

  Walking& w = b.walking;
  w.liftoff = rows3(walking, "liftoff", n, who);
  w.hips.clear();
  for (nb::handle hip : nb::list(walking.attr("hips")))
    w.hips.emplace_back(nb::cast<double>(hip[0]), nb::cast<double>(hip[1]));
  w.height = nb::cast<double>(walking.attr("height"));
  w.com_offset = binding::vector3(walking, "com_offset", who);
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

  GaitScheduler& s = w.scheduler;
  nb::object gait = scheduler.attr("gait");
  s.duty_factor = nb::cast<double>(gait.attr("duty_factor"));
  s.cycle_time = nb::cast<double>(scheduler.attr("cycle_time"));
  s.phase = nb::cast<double>(scheduler.attr("phase"));
  s.t = nb::cast<double>(scheduler.attr("t"));
  nb::object states = leg_states();
  nb::object stance = states.attr("STANCE"), swing = states.attr("SWING");
  s.legs.assign(n, Leg{});
  for (std::size_t i = 0; i < n; ++i) {
    nb::object py_leg = legs[i];
    Leg& leg = s.legs[i];
    leg.offset = nb::cast<double>(gait.attr("offsets")[py_leg.attr("role")]);
    nb::object state = py_leg.attr("state");
    leg.state = state.is(stance)  ? LegState::kStance
                : state.is(swing) ? LegState::kSwing
                                  : LegState::kReaching;
    leg.since = nb::cast<double>(py_leg.attr("since"));
    leg.swing_duration = nb::cast<double>(py_leg.attr("swing_duration"));
    nb::object unload_start = py_leg.attr("unload_start");
    leg.unloading = !unload_start.is_none();
    leg.unload_start = leg.unloading ? nb::cast<double>(unload_start) : 0.0;
    leg.last_cycle = nb::cast<long>(py_leg.attr("last_cycle"));
  }
}

/// The walking state into the Python objects: the scalars every tick, a leg's fields only when
/// they changed, the arrays in place.
void write_state(const WalkingBehaviour& b, const WalkingBehaviour& before, nb::handle walking) {
  const Walking& w = b.walking;
  walking.attr("t") = w.t;
  walking.attr("command") = nb::make_tuple(w.command(0), w.command(1), w.command(2));
  walking.attr("yaw_ref") = w.yaw_ref;
  walking.attr("measured_twist") =
      nb::make_tuple(w.measured_twist(0), w.measured_twist(1), w.measured_twist(2));
  const std::size_t n = w.scheduler.legs.size();
  Doubles liftoff = field<Doubles>(walking, "liftoff", 3 * n, "native walking");
  Eigen::Map<RowMatrixX3>(liftoff.data(), static_cast<Eigen::Index>(n), 3) = w.liftoff;
  nb::object posture = walking.attr("posture"), scheduler = walking.attr("scheduler");
  Doubles rotations = field<Doubles>(posture, "_rotations", 9 * n, "native walking");
  Eigen::Map<RowMatrixX3>(rotations.data(), static_cast<Eigen::Index>(3 * n), 3) =
      b.previous_rotations;
  scheduler.attr("phase") = w.scheduler.phase;
  scheduler.attr("t") = w.scheduler.t;
  nb::object legs = scheduler.attr("legs"), states;
  for (std::size_t i = 0; i < n; ++i) {
    const Leg &now = w.scheduler.legs[i], &then = before.walking.scheduler.legs[i];
    if (now.state == then.state && now.since == then.since &&
        now.swing_duration == then.swing_duration && now.unloading == then.unloading &&
        now.unload_start == then.unload_start && now.last_cycle == then.last_cycle)
      continue;
    if (!states.is_valid()) states = leg_states();
    nb::object leg = legs[i];
    leg.attr("state") = states.attr(now.state == LegState::kStance  ? "STANCE"
                                    : now.state == LegState::kSwing ? "SWING"
                                                                    : "REACHING");
    leg.attr("since") = now.since;
    leg.attr("swing_duration") = now.swing_duration;
    leg.attr("unload_start") = now.unloading ? nb::cast(now.unload_start) : nb::none();
    leg.attr("last_cycle") = now.last_cycle;
  }
}

// ------------------------------------------------------------------------------- BipedStepping
namespace {
constexpr const char* kBiped = "native biped_step";
constexpr const char* kPhaseNames[] = {"dual", "lift_transition", "lift", "land",
                                       "land_transition"};  // biped_step.py Phase's values
// SteppingTimes' fields by name.
constexpr std::pair<const char*, double SteppingTimes::*> kTimes[] = {
    {"dual", &SteppingTimes::dual},
    {"transition", &SteppingTimes::transition},
    {"lift", &SteppingTimes::lift},
    {"land", &SteppingTimes::land},
    {"step_height", &SteppingTimes::step_height},
    {"reversal_time", &SteppingTimes::reversal_time},
    {"impact_velocity_change", &SteppingTimes::impact_velocity_change},
    {"replan_from", &SteppingTimes::replan_from},
    {"reach", &SteppingTimes::reach},
    {"lateral_offset", &SteppingTimes::lateral_offset},
    {"min_width", &SteppingTimes::min_width},
    {"max_width", &SteppingTimes::max_width},
    {"min_swing", &SteppingTimes::min_swing},
    {"max_lateral_speed", &SteppingTimes::max_lateral_speed},
    {"min_lateral_speed", &SteppingTimes::min_lateral_speed},
    {"max_swing", &SteppingTimes::max_swing},
};

}  // namespace

/// The Python `BipedStepping`'s state (biped_step.py) into the twin.
void load_state(BipedSteppingBehaviour& behaviour, nb::handle stepping, const std::string& who) {
  BipedStepping& b = behaviour.stepping;
  nb::object times = stepping.attr("times");
  const std::size_t declared = nb::len(nb::module_::import_("dataclasses").attr("fields")(times));
  if (declared != std::size(kTimes))
    throw nb::value_error("native biped_step: SteppingTimes' fields differ from the kernel's");
  for (const auto& [name, member] : kTimes) b.times.*member = nb::cast<double>(times.attr(name));
  b.height = nb::cast<double>(stepping.attr("height"));
  b.com_height = nb::cast<double>(stepping.attr("com_height"));
  b.yaw = nb::cast<double>(stepping.attr("yaw"));
  nb::object since = stepping.attr("since");
  b.started = !since.is_none();
  b.since = b.started ? nb::cast<double>(since) : 0.0;
  b.t = b.started ? nb::cast<double>(stepping.attr("t")) : 0.0;
  for (int k = 0; k < 3; ++k) b.command(k) = nb::cast<double>(stepping.attr("command")[k]);
  Doubles sides = field<Doubles>(stepping, "sides", 2, who);
  b.sides = Eigen::Map<Eigen::Vector2d>(sides.data());
  b.swing = nb::cast<int>(stepping.attr("swing"));
  if (b.swing != 0 && b.swing != 1) throw nb::value_error("native biped_step: swing is 0 or 1");
  const std::string phase = nb::cast<std::string>(stepping.attr("phase").attr("value"));
  for (int k = 0; k < 5; ++k)
    if (phase == kPhaseNames[k]) b.phase = static_cast<StepPhase>(k);
  b.liftoff = binding::vector3(stepping, "liftoff", who);
  Doubles target = field<Doubles>(stepping, "target", 2, who);
  b.target = Eigen::Map<Eigen::Vector2d>(target.data());
  b.swing_start = nb::cast<double>(stepping.attr("swing_start"));
  b.swing_t0 = nb::cast<double>(stepping.attr("swing_t0"));
  b.swing_u0 = nb::cast<double>(stepping.attr("swing_u0"));
  b.swing_duration = nb::cast<double>(stepping.attr("swing_duration"));
  b.shortened = nb::cast<long>(stepping.attr("shortened"));
  b.lengthened = nb::cast<long>(stepping.attr("lengthened"));
  b.steps = nb::cast<long>(stepping.attr("steps"));
  b.plans = nb::cast<long>(stepping.attr("plans"));
  Doubles plan = field<Doubles>(stepping, "plan", kPlanFields, who);
  std::copy(plan.data(), plan.data() + kPlanFields, b.plan.begin());
}

/// The state into the Python object: t and the heading every tick, the rest when it changed.
void write_state(const BipedSteppingBehaviour& now, const BipedSteppingBehaviour& before,
                 nb::handle stepping) {
  const BipedStepping &b = now.stepping, &then = before.stepping;
  stepping.attr("t") = b.t;
  stepping.attr("yaw") = b.yaw;
  if (b.command != then.command)
    stepping.attr("command") = nb::make_tuple(b.command(0), b.command(1), b.command(2));
  if (b.since != then.since || b.phase != then.phase || b.swing != then.swing ||
      b.steps != then.steps || !then.started) {
    nb::object phases = nb::module_::import_("lab.controller.behaviours.biped_step").attr("Phase");
    stepping.attr("since") = b.since;
    stepping.attr("phase") = phases(kPhaseNames[static_cast<int>(b.phase)]);
    stepping.attr("swing") = b.swing;
    stepping.attr("steps") = b.steps;
  }
  Doubles liftoff = field<Doubles>(stepping, "liftoff", 3, kBiped);
  Eigen::Map<Eigen::Vector3d>(liftoff.data()) = b.liftoff;
  if (b.swing_start != then.swing_start) stepping.attr("swing_start") = b.swing_start;
  if (b.plans != then.plans) {
    Doubles target = field<Doubles>(stepping, "target", 2, kBiped);
    Eigen::Map<Eigen::Vector2d>(target.data()) = b.target;
    Doubles plan = field<Doubles>(stepping, "plan", kPlanFields, kBiped);
    std::copy(b.plan.begin(), b.plan.end(), plan.data());
    stepping.attr("plans") = b.plans;
  }
  if (b.swing_t0 != then.swing_t0 || b.swing_duration != then.swing_duration) {
    stepping.attr("swing_t0") = b.swing_t0;
    stepping.attr("swing_u0") = b.swing_u0;
    stepping.attr("swing_duration") = b.swing_duration;
    stepping.attr("shortened") = b.shortened;
    stepping.attr("lengthened") = b.lengthened;
  }
}

void bind_behaviours(nb::module_& m) {
  m.def("leg_posture_velocity", &leg_posture_velocity_py, nb::arg("contact_positions"),
        nb::arg("contact_rotations"), nb::arg("previous_rotations"), nb::arg("contact_jacobian"),
        nb::arg("radius"), nb::arg("stance"), nb::arg("foot_position"), nb::arg("foot_velocity"),
        nb::arg("base_position"), nb::arg("base_velocity"), nb::arg("base_angular_velocity"),
        nb::arg("height_error"), nb::arg("dt"), nb::arg("damping"), nb::arg("velocity"),
        "LegPostureReference.update's joint velocity references (leg_posture.py) into "
        "`velocity`; `previous_rotations` (the feet's orientations last tick) becomes this "
        "tick's.");
  nb::class_<TickedBehaviour>(m, "NativeBehaviour",
                              "A behaviour's native tick, which the server's native tick runs "
                              "(ServerTick; cpp/behaviours/native_behaviour.hpp).");
  binding::bind<WalkingBehaviour>(
      m, "Walking", "native walking",
      "The native tick of a Python Walking (walking.py): walking.cpp with gait, footholds, swing "
      "and leg_posture.");
  binding::bind<BipedSteppingBehaviour>(
      m, "BipedStepping", kBiped,
      "The native tick of a Python BipedStepping (biped_step.py): biped_step.cpp with pipm and "
      "swing.");
  bind_standing_behaviours(m);
}

}  // namespace lab
