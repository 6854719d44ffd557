// lab::ServerTick: the session's tick (lab/world/session.py Session.tick and _control, in their
// order) in one call on the plant's MjModel / MjData (plant/mujoco_step.hpp), the native kernel
// (controller.hpp), the behaviour's native tick (behaviours/native_behaviour.hpp) and the realism
// layer (realism/layer.hpp) when it is not ideal, the touch detector on the estimated contact
// forces (realism/contact_estimate.hpp) when one is set: the state check, the true state, its
// measurement through the layer (Session._measure), the sensing (touch, and the feet's forces
// when a task reads them: the truth, as the Python tick's), the model update at the measured
// state, the behaviour, the references, the solve, the torques through the layer's delay and
// actuator (Session._actuated) into ctrl, mj_step, the check after it and the fall check's
// contact test. The parts that change at human rates (the references object, the behaviour and
// its twin, the realism layer, the estimator, the sensing) are set once through setters, so a tick
// takes only what changes every tick (the command). What telemetry and the drawing state read goes
// into preallocated arrays (`buffers`), the controller's report stays here until asked for
// (`outcome`); how the tick went comes back as one int (a status and flags), which
// lab/world/native_tick.py turns into the Python path's exceptions (the same events). Compiled
// into lab._kernel when MuJoCo's headers and libmujoco are found (CMakeLists.txt): one module
// holds the kernel, the behaviours and this, so no object crosses between extension modules.
#include <mujoco/mujoco.h>
#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/string.h>

#include <chrono>
#include <cstdint>
#include <optional>
#include <tuple>
#include <vector>

#include "behaviours/native_behaviour.hpp"
#include "estimation/estimator.hpp"
#include "plant/mujoco_step.hpp"
#include "realism/contact_estimate.hpp"
#include "realism/layer.hpp"
#include "tick_outcome.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace lab {
namespace {

using Indices = nb::ndarray<const long long, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using InVector = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using InFlags = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Clock = std::chrono::steady_clock;

/// How a tick ended (native_tick.py's TickStatus mirrors these values).
enum TickStatus : int {
  kStepped = 0,         // controlled, torques applied, stepped, the new state valid
  kDivergedBefore = 1,  // the state was not valid before control (nothing ran)
  kControlFailed = 2,   // the controller failed (the outcome says why): nothing applied, no step
  kDivergedAfter = 3,   // stepped, and the new state is not valid
};
/// Flags or-ed into the status a tick returns (native_tick.py's UNSOLVED and BEHAVIOUR_RAN).
enum TickFlags : int {
  kUnsolved = 4,      // the controller ran and its status is not ok: capped, fallback, violated
  kBehaviourRan = 8,  // the behaviour's native twin ran this tick
};

template <typename T>
T* address_of(const nb::handle& object) {
  return reinterpret_cast<T*>(nb::cast<std::uintptr_t>(object.attr("_address")));
}

std::vector<int> as_ints(const Indices& a) { return {a.data(), a.data() + a.size()}; }

class ServerTick {
 public:
  ServerTick(nb::object kernel, nb::object mj_model, nb::object mj_data, const Indices& q_order,
             const Indices& v_order, const Indices& terrain, const Indices& foot_of_geom,
             int n_feet)
      : kernel_object_(std::move(kernel)),
        model_object_(std::move(mj_model)),
        data_object_(std::move(mj_data)),
        kernel_(nb::cast<Kernel&>(kernel_object_)),
        plant_(address_of<const mjModel>(model_object_), address_of<mjData>(data_object_),
               as_ints(q_order), as_ints(v_order), as_ints(terrain), as_ints(foot_of_geom),
               n_feet) {
    const RobotModel& robot = kernel_.robot();
    if (plant_.nq() != robot.nq || plant_.nv() != robot.nv || plant_.nu() != robot.na ||
        n_feet != static_cast<int>(robot.contacts.size()))
      throw std::invalid_argument(
          "ServerTick: the plant's q, v, actuators and feet differ from the kernel's model");
    q_.resize(robot.nq);
    v_.resize(robot.nv);
    tau_.setZero(robot.na);
    applied_.setZero(robot.na);
    x_.setZero(robot.nx);
    foot_forces_.setZero(3 * n_feet);
    normal_forces_.setZero(n_feet);
    touching_.assign(static_cast<std::size_t>(n_feet), false);
  }

  /// The Python References object the controller reads each tick (read after the behaviour).
  void set_references(nb::object refs) { refs_ = std::move(refs); }

  /// The behaviour `owner` whose twin ticks on the Python RobotModel `robot`; `twin` null for an
  /// idle behaviour (its update changes nothing: no touch sensing either).
  void set_behaviour(nb::object owner, nb::object robot, nb::object twin, double touch_force) {
    twin_ = twin.is_none() ? nullptr : nb::cast<TickedBehaviour*>(twin);
    owner_ = std::move(owner);
    robot_ = std::move(robot);
    twin_object_ = std::move(twin);
    touch_force_ = touch_force;
  }

  /// The realism layer between plant and controller, null when ideal (the controller reads the
  /// truth, the plant applies its torques); `estimator` null unless the `estimator` knob is ekf
  /// (then the base the controller reads is its estimate from the feet in the references'
  /// contact_active, read before the behaviour's tick); `sensing`: a task reads the feet's forces
  /// and the applied torques (Kim eq. 12).
  void set_measurement(nb::object layer, nb::object estimator, bool sensing) {
    layer_ = layer.is_none() ? nullptr : nb::cast<realism::Layer*>(layer);
    estimator_ = estimator.is_none() ? nullptr : nb::cast<estimation::BaseEstimator*>(estimator);
    layer_object_ = std::move(layer);
    estimator_object_ = std::move(estimator);
    sensing_ = sensing;
  }

  /// One server tick (module comment) on the parts set: `command` [vx, vy, yaw_rate], `reload`
  /// (the behaviour's state changed in Python since its twin's last tick), `applied_torques`
  /// (the torques applied last tick, N m: needed when sensing). Returns a TickStatus or-ed with
  /// TickFlags; the controller's report is `outcome()` until the next tick.
  int tick(const InVector& command, bool reload, std::optional<InVector> applied_torques) {
    if (!refs_.is_valid() || !owner_.is_valid())
      throw std::invalid_argument("ServerTick.tick: set_references and set_behaviour first");
    if (command.shape(0) != 3)
      throw std::invalid_argument("ServerTick.tick: command needs 3 entries");
    if (sensing_ &&
        (!applied_torques || applied_torques->shape(0) != static_cast<std::size_t>(tau_.size())))
      throw std::invalid_argument("ServerTick.tick: sensing needs applied_torques, na of them");
    const auto start = Clock::now();
    behaviour_ran_ = false;
    non_foot_contact_ = false;
    has_outcome_ = false;
    call_seconds_ = control_seconds_ = 0.0;
    valid_time_ = plant_.check();  // a state set from outside (fault injection) before control
    if (valid_time_ < 0.0) return kDivergedBefore;
    tick_time_ = valid_time_;
    plant_.state(q_.data(), v_.data());  // the truth: touch, fall check and actuators read it
    if (layer_ != nullptr || estimator_ != nullptr) {  // the controller reads the measured state
      if (layer_ != nullptr)
        std::tie(qm_, vm_) = layer_->measure(q_, v_);
      else
        qm_ = q_, vm_ = v_;
      if (estimator_ != nullptr) {  // its base estimated (lab/world/estimator.py)
        InFlags contacts;           // the controller's (last tick's), as Session._measure
        if (!nb::try_cast(refs_.attr("contact_active"), contacts) ||
            contacts.shape(0) != touching_.size())
          throw std::invalid_argument("ServerTick.tick: the estimator needs one contact per foot");
        contacts_ = Eigen::Map<const estimation::Flags>(contacts.data(), contacts.shape(0));
        estimator_->read(q_, v_, qm_, vm_, contacts_);
      }
      kernel_.update(qm_, vm_);  // fills the Python model's arrays too (Kernel::on_update)
    } else {
      kernel_.update(q_, v_);
    }
    if (sensing_) {  // measured only for a task that reads it (Kim eq. 12)
      plant_.foot_forces(foot_forces_.data());
      kernel_.set_sensing(foot_forces_,
                          Eigen::Map<const Eigen::VectorXd>(applied_torques->data(), tau_.size()));
    }
    if (twin_ != nullptr) {
      plant_.foot_normal_forces(normal_forces_.data());  // touch: sensing, not control
      for (Eigen::Index i = 0; i < normal_forces_.size(); ++i)
        touching_[static_cast<std::size_t>(i)] = normal_forces_(i) > touch_force_;
      if (touch_ != nullptr) {  // realism's contact_estimate: from last tick's applied torques
        const RobotModel& model = kernel_.robot();  // at the measured state
        touching_ = touch_->update(model, applied_, model.v.tail(model.na), touching_.data());
      }
      twin_->tick(owner_, robot_, plant_.time(), command.data(),
                  reinterpret_cast<const bool*>(touching_.data()), touching_.size(), reload);
      behaviour_ran_ = true;
    }
    const int ran = behaviour_ran_ ? kBehaviourRan : 0;
    read_references(kernel_, refs_);
    const TickResult& result = kernel_.solve();
    outcome_.record(kernel_, result);  // in the last tick's storage: no allocation
    has_outcome_ = true;
    const TickOutcome& outcome = outcome_;
    control_seconds_ = std::chrono::duration<double>(Clock::now() - start).count();
    if (!outcome.ok) return kControlFailed | ran;
    // as NativeOutput.solve_status: not ok when capped, a level fell back or a row is violated
    bool solved = !outcome.capped && outcome.violations.empty();
    for (const LevelStatus level : outcome.levels)
      solved = solved && level != LevelStatus::kept_above;
    const int flags = ran | (solved ? 0 : kUnsolved);
    tau_ = result.tau;
    x_ = result.solution.x;
    if (layer_ != nullptr) {  // the command delay and the actuator; copied, not moved: the
      const Eigen::VectorXd applied = layer_->actuate(tau_, q_, v_);  // buffers view applied_
      applied_ = applied;
    } else {
      applied_ = tau_;
    }
    plant_.set_torques(applied_.data());
    const double after = plant_.step();
    if (after < 0.0) return kDivergedAfter | flags;
    valid_time_ = after;
    non_foot_contact_ = plant_.non_foot_ground_contact();
    call_seconds_ = std::chrono::duration<double>(Clock::now() - start).count();
    return kStepped | flags;
  }

  /// The controller's report of the last tick (a copy: it stays that tick's), None when the
  /// controller did not run (the state was not valid before control).
  std::optional<TickOutcome> outcome() const {
    return has_outcome_ ? std::optional<TickOutcome>(outcome_) : std::nullopt;
  }

  /// The touch detector whose flags the behaviour reads instead of MuJoCo's (realism's
  /// `contact_estimate`; None: MuJoCo's): it reads last tick's torques from the `applied`
  /// buffer, which the caller writes when a tick ran elsewhere.
  void set_touch_estimator(nb::object estimator) {
    realism::ContactEstimator* touch = nullptr;
    if (!estimator.is_none()) {
      touch = nb::cast<realism::ContactEstimator*>(estimator);
      const RobotModel& robot = kernel_.robot();
      if (touch->n_joints() != robot.na ||
          touch->n_feet() != static_cast<int>(robot.contacts.size()))
        throw std::invalid_argument(
            "ServerTick.set_touch_estimator: the estimator's joints and feet differ from the "
            "kernel's model");
    }
    touch_object_ = std::move(estimator);
    touch_ = touch;
  }

  /// Views of the arrays the tick writes: q and v (the plant's true state before the step), tau
  /// and x (the controller's torques and [q̈, F] when it succeeded), applied (the torques the
  /// plant applied: tau through the realism layer), foot_forces (n x 3, when sensed),
  /// normal_forces and touching (when the behaviour ran).
  nb::dict buffers() {
    nb::handle self = nb::find(this);
    nb::dict out;
    out["q"] = view(self, q_.data(), {static_cast<std::size_t>(q_.size())});
    out["v"] = view(self, v_.data(), {static_cast<std::size_t>(v_.size())});
    out["tau"] = view(self, tau_.data(), {static_cast<std::size_t>(tau_.size())});
    out["x"] = view(self, x_.data(), {static_cast<std::size_t>(x_.size())});
    out["applied"] = view(self, applied_.data(), {static_cast<std::size_t>(applied_.size())});
    out["foot_forces"] =
        view(self, foot_forces_.data(), {static_cast<std::size_t>(foot_forces_.size() / 3), 3});
    out["normal_forces"] =
        view(self, normal_forces_.data(), {static_cast<std::size_t>(normal_forces_.size())});
    return out;
  }

  double valid_time() const { return valid_time_; }
  double tick_time() const { return tick_time_; }
  double control_seconds() const { return control_seconds_; }
  double call_seconds() const { return call_seconds_; }
  bool behaviour_ran() const { return behaviour_ran_; }
  bool non_foot_contact() const { return non_foot_contact_; }

 private:
  static nb::object view(nb::handle self, double* data, std::initializer_list<std::size_t> shape) {
    return nb::cast(nb::ndarray<nb::numpy, double>(data, shape.size(), shape.begin(), self),
                    nb::rv_policy::reference);
  }

  nb::object kernel_object_, model_object_, data_object_, touch_object_;  // keep them alive
  Kernel& kernel_;
  // the parts set by the setters; the objects keep the raw pointers' owners alive
  nb::object refs_, owner_, robot_, twin_object_, layer_object_, estimator_object_;
  TickedBehaviour* twin_ = nullptr;
  realism::Layer* layer_ = nullptr;
  estimation::BaseEstimator* estimator_ = nullptr;
  bool sensing_ = false;
  double touch_force_ = 0.0;
  TickOutcome outcome_;  // the last tick's report, when has_outcome_ (the controller ran)
  bool has_outcome_ = false;
  MujocoStep plant_;
  realism::ContactEstimator* touch_ = nullptr;  // touch_object_'s
  Eigen::VectorXd q_, v_, qm_, vm_, tau_, applied_, x_, foot_forces_, normal_forces_;
  estimation::Flags contacts_;
  std::vector<char> touching_;  // bools: std::vector<bool> has no data()
  double valid_time_ = 0.0, tick_time_ = 0.0, control_seconds_ = 0.0, call_seconds_ = 0.0;
  bool behaviour_ran_ = false, non_foot_contact_ = false;
};

}  // namespace

void bind_server_tick(nb::module_& m) {
  nb::class_<ServerTick>(m, "ServerTick",
                         "The session's tick in one call (cpp/plant/server_tick.cpp).")
      .def(nb::init<nb::object, nb::object, nb::object, const Indices&, const Indices&,
                    const Indices&, const Indices&, int>(),
           "kernel"_a, "mj_model"_a, "mj_data"_a, "q_order"_a, "v_order"_a, "terrain"_a,
           "foot_of_geom"_a, "n_feet"_a,
           "On a Kernel and the plant's MjModel and MjData, with PlantStep's indices.")
      .def("set_references", &ServerTick::set_references, "refs"_a,
           "The References object (lab/controller/references.py) the controller reads each tick.")
      .def("set_behaviour", &ServerTick::set_behaviour, "owner"_a, "robot"_a, "twin"_a.none(),
           "touch_force"_a,
           "The behaviour `owner` and its native twin (None: idle, no touch sensing), ticking on "
           "the Python RobotModel `robot`; a foot touches when pressing harder than "
           "`touch_force` (N).")
      .def("set_measurement", &ServerTick::set_measurement, "realism"_a.none(),
           "estimator"_a.none(), "sensing"_a,
           "`realism`: a RealismLayer between plant and controller, None when ideal; "
           "`estimator`: an EkfEstimator for the base the controller reads, from the feet in the "
           "references' contact_active; `sensing`: a task reads the feet's forces.")
      .def("tick", &ServerTick::tick, "command"_a, "reload"_a,
           "applied_torques"_a.none() = nb::none(),
           "One server tick on the parts set: a status (0 stepped, 1 diverged before control, 2 "
           "the controller failed (nothing applied), 3 diverged after the step) or-ed with 4 when "
           "the controller's status is not ok and 8 when the behaviour's twin ran.")
      .def("outcome", &ServerTick::outcome,
           "The controller's TickOutcome of the last tick (a copy), None when it did not run.")
      .def("set_touch_estimator", &ServerTick::set_touch_estimator, "estimator"_a.none(),
           "The ContactEstimator whose touch flags the behaviour reads from now on instead of "
           "MuJoCo's (None: MuJoCo's); it reads last tick's torques from the `applied` buffer.")
      .def("buffers", &ServerTick::buffers,
           "Views of the arrays each tick writes (q, v, tau, applied, x, foot_forces, "
           "normal_forces).")
      .def_prop_ro("valid_time", &ServerTick::valid_time,
                   "The sim time of the last state found valid (s).")
      .def_prop_ro("tick_time", &ServerTick::tick_time,
                   "The sim time the last tick controlled at, before its step (s).")
      .def_prop_ro("control_seconds", &ServerTick::control_seconds,
                   "Seconds from the state check to the solve's end, last tick.")
      .def_prop_ro("call_seconds", &ServerTick::call_seconds,
                   "Seconds of the whole last tick inside C++, when it stepped (else 0).")
      .def_prop_ro("behaviour_ran", &ServerTick::behaviour_ran,
                   "Whether the last tick ran the behaviour's native tick.")
      .def_prop_ro("non_foot_contact", &ServerTick::non_foot_contact,
                   "Whether a robot geom other than the feet touched the terrain after the step.");
}

}  // namespace lab
