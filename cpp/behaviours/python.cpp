// Python bindings of the behaviours' hot parts: LegPostureReference, Walking and BipedStepping
// call them on native ticks.
#include "behaviours/python.hpp"

#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <string>
#include <utility>
#include <vector>

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

// ------------------------------------------------------------------------------- Walking
using Doubles = nb::ndarray<double, nb::c_contig, nb::device::cpu>;
using Flags = nb::ndarray<bool, nb::c_contig, nb::device::cpu>;

/// `owner.name` as a C-contiguous array of `size` entries (taken in place, never copied);
/// raises ValueError naming the behaviour (`who`) and the field otherwise.
template <typename Array>
Array field(nb::handle owner, const char* name, std::size_t size,
            const char* who = "native walking") {
  Array array;
  if (!nb::try_cast(owner.attr(name), array, false) || array.size() != size)
    throw nb::value_error((std::string(who) + ": " + name + " must be a C-contiguous " +
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
class WalkingBinding : public NativeBehaviour {
 public:
  void update(nb::handle walking, nb::handle robot, double t,
              nb::ndarray<const double, nb::shape<3>, nb::c_contig, nb::device::cpu> command,
              nb::ndarray<const bool, nb::shape<-1>, nb::c_contig, nb::device::cpu> touching,
              bool reload) {
    tick(walking, robot, t, command.data(), touching.data(), touching.shape(0), reload);
  }

  void tick(nb::handle walking, nb::handle robot, double t, const double* command,
            const bool* touching, std::size_t feet, bool reload) override {
    if (reload || !robot.is(robot_)) load(walking, robot);
    const std::size_t n = core_.scheduler.legs.size();
    if (feet != n) throw nb::value_error("native walking: `touching` needs one flag per foot");
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
    core_.update(t, model, command, touching, refs, posture);
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

// ------------------------------------------------------------------------------- BipedStepping
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

/// The native tick of a Python `BipedStepping` (biped_step.py), as WalkingBinding for Walking:
/// `update` loads the Python object's state when told it changed (or on a new robot model),
/// runs lab::BipedStepping::update on the model's and the references' arrays in place, and
/// writes the state back (the scalars that changed, the arrays in place).
class BipedSteppingBinding : public NativeBehaviour {
 public:
  void update(nb::handle stepping, nb::handle robot, double t,
              nb::ndarray<const double, nb::shape<3>, nb::c_contig, nb::device::cpu> command,
              nb::ndarray<const bool, nb::shape<2>, nb::c_contig, nb::device::cpu> touching,
              bool reload) {
    tick(stepping, robot, t, command.data(), touching.data(), 2, reload);
  }

  void tick(nb::handle stepping, nb::handle robot, double t, const double* command,
            const bool* touching, std::size_t feet, bool reload) override {
    if (feet != 2) throw nb::value_error("native biped_step: `touching` needs two flags");
    if (reload || !robot.is(robot_)) load(stepping, robot);
    before_ = core_;
    const BipedModel model{
        Eigen::Map<const Eigen::VectorXd>(q_.data(), static_cast<Eigen::Index>(q_.size())),
        Eigen::Map<const RowMatrix3>(model_rotation_.data()),
        Eigen::Map<const RowMatrixX3>(contact_positions_.data(), 2, 3),
        Eigen::Map<const Eigen::Vector3d>(model_com_.data()),
        Eigen::Map<const Eigen::Vector3d>(com_velocity_.data())};
    BipedReferences refs{contact_active_.data(),
                         swing_tracked_.data(),
                         Eigen::Map<Eigen::Vector2d>(force_weight_.data()),
                         rows3(foot_position_),
                         rows3(foot_velocity_),
                         rows3(foot_acceleration_),
                         vector(posture_),
                         Eigen::Map<RowMatrix3>(base_rotation_.data()),
                         Eigen::Map<Eigen::Vector3d>(base_angular_velocity_.data()),
                         Eigen::Map<Eigen::Vector3d>(com_.data()),
                         base_height_};
    core_.update(t, model, command, touching, refs);
    base_height_ = refs.base_height;
    write_back(stepping);
  }

 private:
  void load(nb::handle stepping, nb::handle robot) {
    const std::size_t nq = nb::len(nb::object(robot.attr("q")));
    if (nq < 7) throw nb::value_error("native biped_step: the model needs a floating base");
    q_ = field<Doubles>(robot, "q", nq, kBiped);
    model_rotation_ = field<Doubles>(robot, "base_rotation", 9, kBiped);
    contact_positions_ = field<Doubles>(robot, "contact_positions", 6, kBiped);
    model_com_ = field<Doubles>(robot, "com", 3, kBiped);
    com_velocity_ = field<Doubles>(robot, "com_velocity", 3, kBiped);
    nb::object refs = stepping.attr("references");
    contact_active_ = field<Flags>(refs, "contact_active", 2, kBiped);
    swing_tracked_ = field<Flags>(refs, "swing_tracked", 2, kBiped);
    force_weight_ = field<Doubles>(refs, "force_weight", 2, kBiped);
    foot_position_ = field<Doubles>(refs, "foot_position", 6, kBiped);
    foot_velocity_ = field<Doubles>(refs, "foot_velocity", 6, kBiped);
    foot_acceleration_ = field<Doubles>(refs, "foot_acceleration", 6, kBiped);
    posture_ = field<Doubles>(refs, "posture", nq - 7, kBiped);
    base_angular_velocity_ = field<Doubles>(refs, "base_angular_velocity", 3, kBiped);
    com_ = field<Doubles>(refs, "com", 3, kBiped);
    base_height_ = nb::cast<double>(refs.attr("base_height"));
    // The references' base rotation becomes an array this binding writes in place (a Python
    // tick replaces it).
    refs.attr("base_rotation") = nb::module_::import_("numpy").attr("eye")(3);
    base_rotation_ = field<Doubles>(refs, "base_rotation", 9, kBiped);
    liftoff_ = field<Doubles>(stepping, "liftoff", 3, kBiped);
    target_ = field<Doubles>(stepping, "target", 2, kBiped);
    plan_ = field<Doubles>(stepping, "plan", kPlanFields, kBiped);
    Doubles sides = field<Doubles>(stepping, "sides", 2, kBiped);

    BipedStepping& b = core_;
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
    b.sides = Eigen::Map<Eigen::Vector2d>(sides.data());
    b.swing = nb::cast<int>(stepping.attr("swing"));
    if (b.swing != 0 && b.swing != 1) throw nb::value_error("native biped_step: swing is 0 or 1");
    nb::object phases = nb::module_::import_("lab.controller.behaviours.biped_step").attr("Phase");
    const std::string phase = nb::cast<std::string>(stepping.attr("phase").attr("value"));
    for (int k = 0; k < 5; ++k) {
      phases_[k] = phases(kPhaseNames[k]);
      if (phase == kPhaseNames[k]) b.phase = static_cast<StepPhase>(k);
    }
    b.liftoff = Eigen::Map<Eigen::Vector3d>(liftoff_.data());
    b.target = Eigen::Map<Eigen::Vector2d>(target_.data());
    b.swing_start = nb::cast<double>(stepping.attr("swing_start"));
    b.swing_t0 = nb::cast<double>(stepping.attr("swing_t0"));
    b.swing_u0 = nb::cast<double>(stepping.attr("swing_u0"));
    b.swing_duration = nb::cast<double>(stepping.attr("swing_duration"));
    b.shortened = nb::cast<long>(stepping.attr("shortened"));
    b.lengthened = nb::cast<long>(stepping.attr("lengthened"));
    b.steps = nb::cast<long>(stepping.attr("steps"));
    b.plans = nb::cast<long>(stepping.attr("plans"));
    std::copy(plan_.data(), plan_.data() + kPlanFields, b.plan.begin());
    refs_ = refs;
    robot_ = nb::borrow(robot);
  }

  /// The state into the Python objects: t, the heading and the base height every tick, the
  /// rest when it changed.
  void write_back(nb::handle stepping) {
    const BipedStepping &b = core_, &then = before_;
    stepping.attr("t") = b.t;
    stepping.attr("yaw") = b.yaw;
    if (b.command != then.command)
      stepping.attr("command") = nb::make_tuple(b.command(0), b.command(1), b.command(2));
    refs_.attr("base_height") = base_height_;
    if (b.since != then.since || b.phase != then.phase || b.swing != then.swing ||
        b.steps != then.steps || !then.started) {
      stepping.attr("since") = b.since;
      stepping.attr("phase") = phases_[static_cast<int>(b.phase)];
      stepping.attr("swing") = b.swing;
      stepping.attr("steps") = b.steps;
    }
    Eigen::Map<Eigen::Vector3d>(liftoff_.data()) = b.liftoff;
    if (b.swing_start != then.swing_start) stepping.attr("swing_start") = b.swing_start;
    if (b.plans != then.plans) {
      Eigen::Map<Eigen::Vector2d>(target_.data()) = b.target;
      std::copy(b.plan.begin(), b.plan.end(), plan_.data());
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

  BipedStepping core_, before_;
  nb::object robot_, refs_;
  nb::object phases_[5];
  Doubles q_, model_rotation_, contact_positions_, model_com_, com_velocity_;
  Flags contact_active_, swing_tracked_;
  Doubles force_weight_, foot_position_, foot_velocity_, foot_acceleration_, posture_,
      base_rotation_, base_angular_velocity_, com_, liftoff_, target_, plan_;
  double base_height_ = 0.0;
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
  nb::class_<NativeBehaviour>(m, "NativeBehaviour",
                              "A behaviour's native tick, which the server's native tick runs "
                              "(ServerTick; cpp/behaviours/native_behaviour.hpp).");
  nb::class_<WalkingBinding, NativeBehaviour>(
      m, "Walking", "The native tick of a Python Walking (walking.py), in one call.")
      .def(nb::init<>())
      .def("update", &WalkingBinding::update, nb::arg("walking"), nb::arg("robot"), nb::arg("t"),
           nb::arg("command"), nb::arg("touching"), nb::arg("reload"),
           "Walking.update's steps in C++ (cpp/behaviours/walking.cpp) on the model's and the "
           "references' arrays in place; `reload`: the Python object's state changed since the "
           "last call (a Python tick, configure, continue_from) and is read first. The walking "
           "state is written back to the Python objects.");
  nb::class_<BipedSteppingBinding, NativeBehaviour>(
      m, "BipedStepping", "The native tick of a Python BipedStepping (biped_step.py), in one call.")
      .def(nb::init<>())
      .def("update", &BipedSteppingBinding::update, nb::arg("stepping"), nb::arg("robot"),
           nb::arg("t"), nb::arg("command"), nb::arg("touching"), nb::arg("reload"),
           "BipedStepping.update's steps in C++ (cpp/behaviours/biped_step.cpp, pipm.cpp) on "
           "the model's and the references' arrays in place; `reload`: the Python object's "
           "state changed since the last call and is read first. The state is written back.");
}

}  // namespace lab
