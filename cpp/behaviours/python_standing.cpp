// Python bindings of the standing behaviours' twins (Balance's line balance, Squat, Stance,
// ComEllipse, StaticWalk, HeightStep, ForwardShift): their state's load and write-back for
// binding.hpp's Binding. Each Python behaviour holds one and calls it on a native tick
// (behaviours/native.py).
#include <nanobind/stl/vector.h>

#include <string>
#include <vector>

#include "behaviours/balance.hpp"
#include "behaviours/binding.hpp"
#include "behaviours/body_motion.hpp"
#include "behaviours/com_ellipse.hpp"
#include "behaviours/python.hpp"
#include "behaviours/squat.hpp"
#include "behaviours/stance.hpp"
#include "behaviours/static_walk.hpp"

namespace nb = nanobind;

namespace lab {

using binding::Doubles;
using binding::field;
using binding::vector3;

namespace {

/// A scripted behaviour's `start` (None before its first tick) into its clock, and back once
/// the first tick set it.
void load_clock(MotionClock& clock, nb::handle behaviour) {
  nb::object start = behaviour.attr("start");
  clock.started = !start.is_none();
  clock.start = clock.started ? nb::cast<double>(start) : 0.0;
}
void write_clock(const MotionClock& clock, const MotionClock& before, nb::handle behaviour) {
  if (!before.started) behaviour.attr("start") = clock.start;
}

}  // namespace

/// The Python class's state into the native twin (the same names), and the state a tick
/// changes back into it; one pair per behaviour (binding.hpp).
void load_state(Balance& b, nb::handle balance, const std::string& who) {
  b.on_line = nb::cast<bool>(balance.attr("_on_line"));
  b.com_on_line = vector3(balance, "_com_on_line", who);
  Doubles inertia = field<Doubles>(balance, "_inertia", 9, who);
  b.inertia = Eigen::Map<const RowMatrix3>(inertia.data());
  nb::object gains = balance.attr("line_gains");
  b.line_gains = {nb::cast<double>(gains.attr("omega")), nb::cast<double>(gains.attr("damping")),
                  nb::cast<double>(gains.attr("max_offset"))};
}
void write_state(const Balance&, const Balance&, nb::handle) {}

void load_state(Squat& s, nb::handle squat, const std::string& who) {
  load_state(static_cast<Balance&>(s), squat, who);
  s.centre = vector3(squat, "centre", who);
  s.amplitude = vector3(squat, "amplitude", who);
  s.period = nb::cast<double>(squat.attr("period"));
  load_clock(s.clock, squat);
}
void write_state(const Squat& s, const Squat& before, nb::handle squat) {
  write_clock(s.clock, before.clock, squat);
}

void load_state(ComEllipse& e, nb::handle ellipse, const std::string& who) {
  load_state(static_cast<Balance&>(e), ellipse, who);
  e.along = vector3(ellipse, "along", who);
  e.centre = vector3(ellipse, "centre", who);
  load_clock(e.clock, ellipse);
}
void write_state(const ComEllipse& e, const ComEllipse& before, nb::handle ellipse) {
  write_clock(e.clock, before.clock, ellipse);
  Doubles on_line = field<Doubles>(ellipse, "_com_on_line", 3, "native ComEllipse");
  Eigen::Map<Eigen::Vector3d>(on_line.data()) = e.com_on_line;
}

void load_state(HeightStep& h, nb::handle step, const std::string& who) {
  h.com = vector3(step, "com", who);
  h.height = nb::cast<double>(step.attr("height"));
  load_clock(h.clock, step);
}
void write_state(const HeightStep& h, const HeightStep& before, nb::handle step) {
  write_clock(h.clock, before.clock, step);
}

void load_state(ForwardShift& f, nb::handle shift, const std::string& who) {
  f.com = vector3(shift, "com", who);
  load_clock(f.clock, shift);
}
void write_state(const ForwardShift& f, const ForwardShift& before, nb::handle shift) {
  write_clock(f.clock, before.clock, shift);
}

void load_state(StaticWalk& w, nb::handle walk, const std::string& who) {
  nb::object p = walk.attr("parameters");
  w.parameters = {nb::cast<double>(p.attr("shift_time")),  nb::cast<double>(p.attr("swing_time")),
                  nb::cast<double>(p.attr("step_length")), nb::cast<double>(p.attr("step_height")),
                  nb::cast<double>(p.attr("margin")),      nb::cast<double>(p.attr("transition"))};
  nb::object surface = walk.attr("surface");
  w.surface.reset();
  if (!surface.is_none())
    w.surface = HalfCylinder{nb::cast<double>(surface.attr("radius")),
                             nb::cast<double>(surface.attr("axis_height"))};
  const auto order = nb::cast<std::vector<int>>(walk.attr("order"));
  if (order.size() != 4) throw nb::value_error((who + ": the footfall needs four legs").c_str());
  for (std::size_t k = 0; k < 4; ++k) {
    if (order[k] < 0 || order[k] > 3)
      throw nb::value_error((who + ": a footfall leg is out of range").c_str());
    w.order[k] = order[k];
  }
  w.heading = vector3(walk, "heading", who);
  Doubles feet = field<Doubles>(walk, "feet", 12, who);
  w.feet = Eigen::Map<const RowMatrixX3>(feet.data(), 4, 3);
  Doubles lift_off = field<Doubles>(walk, "lift_off", 12, who);
  w.lift_off = Eigen::Map<const RowMatrixX3>(lift_off.data(), 4, 3);
  w.com_start = vector3(walk, "com_start", who);
  w.com_target = vector3(walk, "com_target", who);
  load_clock(w.clock, walk);
  w.step = nb::cast<long>(walk.attr("step"));
}
void write_state(const StaticWalk& w, const StaticWalk& before, nb::handle walk) {
  write_clock(w.clock, before.clock, walk);
  if (w.step == before.step) return;
  walk.attr("step") = w.step;
  const char* who = "native static_walk";
  Doubles feet = field<Doubles>(walk, "feet", 12, who);
  Eigen::Map<RowMatrixX3>(feet.data(), 4, 3) = w.feet;
  Doubles lift_off = field<Doubles>(walk, "lift_off", 12, who);
  Eigen::Map<RowMatrixX3>(lift_off.data(), 4, 3) = w.lift_off;
  Doubles start = field<Doubles>(walk, "com_start", 3, who);
  Eigen::Map<Eigen::Vector3d>(start.data()) = w.com_start;
  Doubles target = field<Doubles>(walk, "com_target", 3, who);
  Eigen::Map<Eigen::Vector3d>(target.data()) = w.com_target;
}

/// A stance's name (stance.py STANCES: "double" or a sole's contact name) as Stance holds it.
static int stance_index(nb::handle name, const std::vector<std::string>& names,
                        const std::string& who) {
  const std::string stance = nb::cast<std::string>(name);
  if (stance == "double") return kDoubleSupport;
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == stance) return static_cast<int>(i);
  throw nb::value_error((who + ": unknown stance " + stance).c_str());
}

void load_state(Stance& s, nb::handle stance, const std::string& who) {
  load_state(static_cast<Balance&>(s), stance, who);
  const auto names = nb::cast<std::vector<std::string>>(stance.attr("names"));
  if (names.size() != 2) throw nb::value_error((who + ": a stance needs two soles").c_str());
  s.stance = stance_index(stance.attr("stance"), names, who);
  s.from = stance_index(stance.attr("_from"), names, who);
  nb::object started = stance.attr("_started"), pending = stance.attr("_pending");
  s.started = !started.is_none();
  s.started_at = s.started ? nb::cast<double>(started) : 0.0;
  s.pending = !pending.is_none();
  s.pending_stance = s.pending ? stance_index(pending, names, who) : kDoubleSupport;
  s.swing_hz = nb::cast<double>(stance.attr("swing_hz"));
  nb::object swing = stance.attr("_swing");
  s.swinging = !swing.is_none();
  s.swing_start = s.swinging ? nb::cast<double>(swing[0]) : 0.0;
  s.swing_frequency = s.swinging ? nb::cast<double>(swing[1]) : 0.0;
  const std::size_t na = nb::len(nb::object(stance.attr("_bend")));
  Doubles lifted = field<Doubles>(stance, "_lifted", na, who);
  s.lifted = Eigen::Map<const Eigen::VectorXd>(lifted.data(), static_cast<Eigen::Index>(na));
  Doubles bend = field<Doubles>(stance, "_bend", na, who);
  s.bend = Eigen::Map<const Eigen::VectorXd>(bend.data(), static_cast<Eigen::Index>(na));
  s.periods_done = nb::cast<long>(stance.attr("_periods_done"));
  s.flexion.clear();
  for (nb::handle joints : stance.attr("_flexion"))
    s.flexion.push_back(nb::cast<std::vector<int>>(joints.attr("tolist")()));
  for (const auto& joints : s.flexion)
    for (int j : joints)
      if (j < 0 || j >= s.bend.size())
        throw nb::value_error((who + ": a flexion joint is out of range").c_str());
  s.weight = nb::cast<double>(stance.attr("weight"));
  s.middle = vector3(stance, "middle", who);
  Doubles ground = field<Doubles>(stance, "_ground", 6, who);
  s.ground = Eigen::Map<const RowMatrixX3>(ground.data(), 2, 3);
}

void write_state(const Stance& s, const Stance& before, nb::handle stance) {
  if (s.stance == before.stance && s.from == before.from && s.started == before.started &&
      s.started_at == before.started_at && s.pending == before.pending &&
      s.swinging == before.swinging && s.swing_start == before.swing_start &&
      s.periods_done == before.periods_done)
    return;
  const auto names = nb::cast<std::vector<std::string>>(stance.attr("names"));
  const auto name = [&names](int i) {
    return i == kDoubleSupport ? std::string("double") : names[static_cast<std::size_t>(i)];
  };
  stance.attr("stance") = name(s.stance);
  stance.attr("_from") = name(s.from);
  stance.attr("_started") = s.started ? nb::cast(s.started_at) : nb::none();
  stance.attr("_pending") = s.pending ? nb::cast(name(s.pending_stance)) : nb::none();
  stance.attr("_swing") =
      s.swinging ? nb::object(nb::make_tuple(s.swing_start, s.swing_frequency)) : nb::none();
  stance.attr("_periods_done") = s.periods_done;
  if (s.swinging && !before.swinging) {  // a swing started: the posture it starts from
    Doubles lifted = field<Doubles>(stance, "_lifted", s.lifted.size(), "native Stance");
    Eigen::Map<Eigen::VectorXd>(lifted.data(), s.lifted.size()) = s.lifted;
  }
}

void bind_standing_behaviours(nb::module_& m) {
  binding::bind<Balance>(m, "Balance", "native balance",
                         "The native tick of a Python Balance (balance.py, line_balance.py).");
  binding::bind<Squat>(m, "Squat", "native squat",
                       "The native tick of a Python Squat or CopSquat (squat.py).");
  binding::bind<Stance>(m, "Stance", "native stance",
                        "The native tick of a Python Stance (stance.py).");
  binding::bind<ComEllipse>(m, "ComEllipse", "native com_ellipse",
                            "The native tick of a Python ComEllipse (com_ellipse.py).");
  binding::bind<StaticWalk>(
      m, "StaticWalk", "native static_walk",
      "The native tick of a Python StaticWalk or StaticWalkHalfCylinder (static_walk.py).");
  binding::bind<HeightStep>(m, "HeightStep", "native height_step",
                            "The native tick of a Python HeightStep (body_motion.py).");
  binding::bind<ForwardShift>(m, "ForwardShift", "native forward_shift",
                              "The native tick of a Python ForwardShift (body_motion.py).");
}

}  // namespace lab
