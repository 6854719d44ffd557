// lab._kernel: the Python face of the native kernel (lab/controller/native.py wraps it).
#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <array>
#include <memory>

#include "behaviours/python.hpp"  // leg_posture_velocity: the walking behaviour's hot part
#include "controller.hpp"
#include "frames.hpp"  // FramePlacements: the drawing state's frames
#if __has_include("hierarchy/python.hpp")
#include "hierarchy/python.hpp"  // solve_hierarchy: the native methods on a given problem
#define LAB_BIND_HIERARCHY
#endif

namespace nb = nanobind;
using namespace nb::literals;

namespace {

using Doubles = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
using Flags = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using ContactTuple = std::tuple<std::string, std::string, std::string, double, double, double>;

/// Any array of doubles, flattened in C order.
void copy_flat(Eigen::VectorXd& dst, const Doubles& a) {
  dst = Eigen::Map<const Eigen::VectorXd>(a.data(), static_cast<Eigen::Index>(a.size()));
}

void copy_vector3(Eigen::Vector3d& dst, const Doubles& a, const char* what) {
  if (a.size() != 3)
    throw std::invalid_argument(std::string("references: ") + what + " needs 3 entries");
  dst = Eigen::Map<const Eigen::Vector3d>(a.data());
}

std::vector<lab::ContactSpec> contact_specs(const std::vector<ContactTuple>& tuples) {
  std::vector<lab::ContactSpec> specs;
  for (const auto& [name, frame, kind, radius, half_length, half_width] : tuples) {
    if (kind != "point" && kind != "flat")
      throw std::invalid_argument("contact '" + name + "': kind must be 'point' or 'flat'");
    specs.push_back({name, frame,
                     kind == "point" ? lab::ContactKind::point : lab::ContactKind::flat, radius,
                     half_length, half_width});
  }
  return specs;
}

/// The array fields of References / WalkReferences, in this order (ReferenceReader::kNames).
constexpr std::size_t kArrayFields = 15;
using ReferenceArrays = std::array<Doubles, kArrayFields>;

/// Copy the references into the kernel; raises ValueError naming a field of the wrong size.
void assign_references(lab::Kernel& k, const ReferenceArrays& a, double base_height,
                       const Flags& contact_active) {
  const auto& [com, posture, base_rotation, com_velocity, base_angular_velocity, normal_force_max,
               base_linear_velocity, com_acceleration, foot_position, foot_velocity,
               foot_acceleration, surface_normal, force_weight, posture_velocity, posture_weight] =
      a;
  lab::References& refs = k.references();
  copy_vector3(refs.com, com, "com");
  copy_flat(refs.posture, posture);
  refs.base_height = base_height;
  if (base_rotation.size() != 9)
    throw std::invalid_argument("references: base_rotation needs 3 x 3 entries");
  refs.base_rotation =
      Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(base_rotation.data());
  copy_vector3(refs.com_velocity, com_velocity, "com_velocity");
  copy_vector3(refs.base_angular_velocity, base_angular_velocity, "base_angular_velocity");
  refs.contact_active = Eigen::Map<const Eigen::Array<bool, Eigen::Dynamic, 1>>(
      contact_active.data(), static_cast<Eigen::Index>(contact_active.size()));
  copy_flat(refs.normal_force_max, normal_force_max);
  copy_vector3(refs.base_linear_velocity, base_linear_velocity, "base_linear_velocity");
  copy_vector3(refs.com_acceleration, com_acceleration, "com_acceleration");
  copy_flat(refs.foot_position, foot_position);
  copy_flat(refs.foot_velocity, foot_velocity);
  copy_flat(refs.foot_acceleration, foot_acceleration);
  copy_flat(refs.surface_normal, surface_normal);
  copy_flat(refs.force_weight, force_weight);
  copy_flat(refs.posture_velocity, posture_velocity);
  copy_flat(refs.posture_weight, posture_weight);
  k.check_references();
}

/// The array fields of SoleReferences (tasks/sole.py) but leg_swinging, in this order
/// (ReferenceReader::kSoleNames).
constexpr std::size_t kSoleFields = 5;
using SoleArrays = std::array<Doubles, kSoleFields>;

/// Copy the sole references into the kernel (empty arrays: not SoleReferences); their sizes are
/// checked with the other fields' (assign_references, and every solve).
void assign_sole_references(lab::Kernel& k, const SoleArrays& a, const Flags& leg_swinging) {
  const auto& [sole_position, sole_rotation, leg_position, leg_velocity, leg_acceleration] = a;
  lab::References& refs = k.references();
  copy_flat(refs.sole_position, sole_position);
  copy_flat(refs.sole_rotation, sole_rotation);
  refs.leg_swinging = Eigen::Map<const Eigen::Array<bool, Eigen::Dynamic, 1>>(
      leg_swinging.data(), static_cast<Eigen::Index>(leg_swinging.size()));
  copy_flat(refs.leg_position, leg_position);
  copy_flat(refs.leg_velocity, leg_velocity);
  copy_flat(refs.leg_acceleration, leg_acceleration);
}

/// Reads a References (or WalkReferences) object's fields straight from Python each tick: an
/// array seen on the last tick is read through the buffer already imported (so a behaviour's
/// in-place change shows), one the behaviour replaced is imported anew. A plain References has
/// no walking fields: they read as empty.
class ReferenceReader {
 public:
  static constexpr const char* kNames[kArrayFields] = {"com",
                                                       "posture",
                                                       "base_rotation",
                                                       "com_velocity",
                                                       "base_angular_velocity",
                                                       "normal_force_max",
                                                       "base_linear_velocity",
                                                       "com_acceleration",
                                                       "foot_position",
                                                       "foot_velocity",
                                                       "foot_acceleration",
                                                       "surface_normal",
                                                       "force_weight",
                                                       "posture_velocity",
                                                       "posture_weight"};
  static constexpr std::size_t kWalkingFrom = 8;  // foot_position on: WalkReferences only
  static constexpr const char* kSoleNames[kSoleFields] = {
      "sole_position", "sole_rotation", "leg_position", "leg_velocity", "leg_acceleration"};

  ReferenceReader() {
    nb::module_ numpy = nb::module_::import_("numpy");
    nb::object empty = numpy.attr("zeros")(0);
    empty_ = nb::cast<Doubles>(empty);
    empty_owner_ = empty;
    // The names as interned Python strings: a lookup by C string builds the str every time.
    const auto interned = [](const char* name) {
      return nb::steal(PyUnicode_InternFromString(name));
    };
    for (std::size_t i = 0; i < kArrayFields; ++i) names_[i] = interned(kNames[i]);
    active_name_ = interned("contact_active");
    height_name_ = interned("base_height");
    nb::object no_flags = numpy.attr("zeros")(0, "dtype"_a = numpy.attr("bool_"));
    no_flags_ = nb::cast<Flags>(no_flags);
    no_flags_owner_ = no_flags;
  }

  void read(lab::Kernel& k, nb::handle refs) {
    nb::handle type = refs.type();
    if (!type.is(type_)) {  // a new References class: does it have the walking fields?
      type_ = nb::borrow(type);
      walking_ = nb::hasattr(refs, "foot_position");
      sole_ = nb::hasattr(refs, "sole_position");
    }
    read_sole(k, refs);  // before the rest, whose assignment checks every field's size
    for (std::size_t i = 0; i < kArrayFields; ++i) {
      if (i >= kWalkingFrom && !walking_) {
        arrays_[i] = empty_;
        seen_[i] = nb::object();
        continue;
      }
      nb::object value = refs.attr(names_[i]);
      if (seen_[i].is_valid() && value.is(seen_[i])) continue;  // the same array as last tick
      arrays_[i] = import<Doubles>(value, kNames[i], seen_[i]);
    }
    nb::object active = refs.attr(active_name_);
    if (!(active_seen_.is_valid() && active.is(active_seen_)))
      active_ = import<Flags>(active, "contact_active", active_seen_);
    const double base_height = nb::cast<double>(refs.attr(height_name_));
    assign_references(k, arrays_, base_height, active_);
  }

 private:
  /// The SoleReferences fields (empty for other references).
  void read_sole(lab::Kernel& k, nb::handle refs) {
    if (!sole_) {
      const lab::References& now = k.references();
      if (!now.sole_position.size() && !now.sole_rotation.size() && !now.leg_swinging.size() &&
          !now.leg_position.size() && !now.leg_velocity.size() && !now.leg_acceleration.size())
        return;  // already empty: nothing to copy on the tick of a robot without soles
      sole_arrays_.fill(empty_);
      for (auto& seen : sole_seen_) seen = nb::object();
      leg_swinging_ = no_flags_;
      leg_swinging_seen_ = nb::object();
    } else {
      for (std::size_t i = 0; i < kSoleFields; ++i) {
        nb::object value = refs.attr(kSoleNames[i]);
        if (sole_seen_[i].is_valid() && value.is(sole_seen_[i])) continue;
        sole_arrays_[i] = import<Doubles>(value, kSoleNames[i], sole_seen_[i]);
      }
      nb::object swinging = refs.attr("leg_swinging");
      if (!(leg_swinging_seen_.is_valid() && swinging.is(leg_swinging_seen_)))
        leg_swinging_ = import<Flags>(swinging, "leg_swinging", leg_swinging_seen_);
    }
    assign_sole_references(k, sole_arrays_, leg_swinging_);
  }

  /// `value` as an array; `seen` keeps it when it was taken without a copy (later ticks then
  /// read it in place), and is cleared otherwise (a converted copy is made again each tick).
  template <typename Array>
  static Array import(const nb::object& value, const char* name, nb::object& seen) {
    Array array;
    if (nb::try_cast(value, array, false)) {
      seen = value;
      return array;
    }
    seen = nb::object();
    if (!nb::try_cast(value, array, true))
      throw std::invalid_argument(std::string("references: ") + name +
                                  " is not an array of the right type");
    return array;
  }

  ReferenceArrays arrays_;
  std::array<nb::object, kArrayFields> seen_;
  Flags active_;
  nb::object active_seen_;
  nb::object type_;
  bool walking_ = false;
  bool sole_ = false;
  SoleArrays sole_arrays_;
  std::array<nb::object, kSoleFields> sole_seen_;
  Flags leg_swinging_;
  nb::object leg_swinging_seen_;
  Doubles empty_;
  nb::object empty_owner_;
  std::array<nb::object, kArrayFields> names_;
  nb::object active_name_, height_name_;
  Flags no_flags_;
  nb::object no_flags_owner_;
};

nb::dict problem_dict(const lab::HierarchyProblem& problem) {
  nb::list levels;
  for (const auto& level : problem.levels)
    levels.append(nb::make_tuple(Eigen::MatrixXd(level.A), Eigen::VectorXd(level.b),
                                 Eigen::MatrixXd(level.C), Eigen::VectorXd(level.d), level.weight));
  nb::dict out;
  out["dynamics_A"] = Eigen::MatrixXd(problem.dynamics_A);
  out["dynamics_b"] = Eigen::VectorXd(problem.dynamics_b);
  out["levels"] = levels;
  out["support"] = Eigen::Array<bool, Eigen::Dynamic, 1>(problem.support);
  return out;
}

/// The Python RobotModel's preallocated arrays (lab/controller/model.py), which the kernel's model
/// update fills in place: one pinocchio pass serves the Python behaviours and the kernel's rows.
class ModelMirror {
 public:
  using Out = nb::ndarray<double, nb::c_contig, nb::device::cpu>;

  ModelMirror(const lab::RobotModel& robot, const nb::dict& arrays) {
    const auto nv = static_cast<std::size_t>(robot.nv), nf = static_cast<std::size_t>(robot.nf);
    const auto nc = robot.contacts.size();
    q_ = take(arrays, "q", {static_cast<std::size_t>(robot.nq)});
    v_ = take(arrays, "v", {nv});
    M_ = take(arrays, "M", {nv, nv});
    h_ = take(arrays, "h", {nv});
    Jc_ = take(arrays, "Jc", {nf, nv});
    Jc_dot_v_ = take(arrays, "Jc_dot_v", {nf});
    com_ = take(arrays, "com", {3});
    com_velocity_ = take(arrays, "com_velocity", {3});
    com_drift_ = take(arrays, "com_drift", {3});
    Jcom_ = take(arrays, "Jcom", {3, nv});
    centroidal_map_ = take(arrays, "centroidal_map", {6, nv});
    base_rotation_ = take(arrays, "base_rotation", {3, 3});
    contact_positions_ = take(arrays, "contact_positions", {nc, 3});
    contact_rotations_ = take(arrays, "contact_rotations", {nc, 3, 3});
  }

  /// Copy the model's state of the last update into the arrays.
  void fill(const lab::RobotModel& robot) {
    vector(q_) = robot.q;
    vector(v_) = robot.v;
    matrix(M_) = robot.M;
    vector(h_) = robot.h;
    matrix(Jc_) = robot.Jc;
    vector(Jc_dot_v_) = robot.Jc_dot_v;
    vector(com_) = robot.com;
    vector(com_velocity_) = robot.com_velocity;
    vector(com_drift_) = robot.com_drift;
    matrix(Jcom_) = robot.Jcom;
    matrix(centroidal_map_) = robot.centroidal_map;
    matrix(base_rotation_) = robot.base_rotation;
    for (std::size_t i = 0; i < robot.contacts.size(); ++i) {
      const auto k = static_cast<Eigen::Index>(i);
      matrix(contact_positions_).row(k) = robot.contact_positions[i].transpose();
      Eigen::Map<RowMajor>(contact_rotations_.data() + 9 * i, 3, 3) = robot.contact_rotations[i];
    }
  }

 private:
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

  static Out take(const nb::dict& arrays, const char* name, std::vector<std::size_t> shape) {
    if (!arrays.contains(name))
      throw std::invalid_argument(std::string("mirror_model: no array '") + name + "'");
    Out array;
    if (!nb::try_cast(arrays[name], array))
      throw std::invalid_argument(std::string("mirror_model: '") + name +
                                  "' is not a writable C-contiguous float64 array");
    bool same = array.ndim() == shape.size();
    for (std::size_t i = 0; same && i < shape.size(); ++i) same = array.shape(i) == shape[i];
    if (!same)
      throw std::invalid_argument(std::string("mirror_model: '") + name + "' has the wrong shape");
    return array;
  }
  static Eigen::Map<Eigen::VectorXd> vector(Out& a) {
    return {a.data(), static_cast<Eigen::Index>(a.size())};
  }
  static Eigen::Map<RowMajor> matrix(Out& a) {
    return {a.data(), static_cast<Eigen::Index>(a.shape(0)), static_cast<Eigen::Index>(a.shape(1))};
  }

  Out q_, v_, M_, h_, Jc_, Jc_dot_v_, com_, com_velocity_, com_drift_, Jcom_, centroidal_map_,
      base_rotation_, contact_positions_, contact_rotations_;
};

using OutVector = nb::ndarray<double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

/// The kernel's ReferenceReader, made at its first use and freed with the kernel.
ReferenceReader& reference_reader(lab::Kernel& k) {
  if (!k.binding_state) k.binding_state = std::make_shared<ReferenceReader>();
  return *static_cast<ReferenceReader*>(k.binding_state.get());
}

nb::tuple tick_tuple(lab::Kernel& kernel, const lab::TickResult& result) {
  const auto& solution = result.solution;
  nb::list statuses;
  for (auto status : solution.levels) statuses.append(lab::level_status_name(status));
  nb::dict errors;
  for (const auto& [name, error] : kernel.task_errors()) errors[name.c_str()] = error;
  return nb::make_tuple(Eigen::VectorXd(result.tau), Eigen::VectorXd(result.qdd),
                        Eigen::VectorXd(result.forces), solution.ok, solution.message, statuses,
                        solution.residuals, solution.qp_solves, errors, solution.level_seconds);
}

/// What a native tick reports besides τ and x, copied out of the kernel so that it stays that
/// tick's after the next one: NativeOutput (native.py) builds its HierarchySolution and task
/// errors from it only when they are read (telemetry reads them at 100 Hz, the loop runs at 1 kHz).
struct TickOutcome {
  bool ok = false;
  std::string message;
  std::vector<lab::LevelStatus> levels;
  std::vector<double> residuals, level_seconds;
  int qp_solves = 0;
  std::vector<std::pair<std::string, double>> task_errors;

  TickOutcome(const lab::Kernel& kernel, const lab::HierarchySolution& solution)
      : ok(solution.ok),
        message(solution.message),
        levels(solution.levels),
        residuals(solution.residuals),
        level_seconds(solution.level_seconds),
        qp_solves(solution.qp_solves) {
    kernel.visit_task_errors(
        [&](const std::string& name, double error) { task_errors.emplace_back(name, error); });
  }
};

template <typename Values, typename Item>
nb::tuple tuple_of(const Values& values, Item&& item) {
  nb::tuple out = nb::steal<nb::tuple>(PyTuple_New(static_cast<Py_ssize_t>(values.size())));
  for (std::size_t i = 0; i < values.size(); ++i)
    PyTuple_SET_ITEM(out.ptr(), static_cast<Py_ssize_t>(i), item(values[i]));
  return out;
}

using InVector = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;

}  // namespace

NB_MODULE(_kernel, m) {
  m.doc() = "The native controller kernel: lab/controller's tick in C++ (see cpp/README.md).";

  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const lab::UnknownName& e) {
      PyErr_SetString(PyExc_KeyError, e.what());
    }
  });

  m.attr("has_solvers") =
#ifdef LAB_HAVE_HIERARCHY_SOLVERS
      true;
#else
      false;
#endif

#ifdef LAB_BIND_HIERARCHY
  lab::bind_hierarchy(m);
#endif
  lab::bind_behaviours(m);
  lab::bind_frame_placements(m);

  nb::class_<TickOutcome>(m, "TickOutcome",
                          "What a tick_into reported besides τ and x (a copy: it stays the "
                          "tick's own).")
      .def_ro("ok", &TickOutcome::ok)
      .def_ro("message", &TickOutcome::message)
      .def_ro("qp_solves", &TickOutcome::qp_solves)
      .def_prop_ro("levels",
                   [](const TickOutcome& o) {
                     return tuple_of(o.levels, [](lab::LevelStatus s) {
                       return PyUnicode_InternFromString(lab::level_status_name(s));
                     });
                   })
      .def_prop_ro("residuals",
                   [](const TickOutcome& o) { return tuple_of(o.residuals, PyFloat_FromDouble); })
      .def_prop_ro(
          "level_seconds",
          [](const TickOutcome& o) { return tuple_of(o.level_seconds, PyFloat_FromDouble); })
      .def_prop_ro(
          "fallback_levels",
          [](const TickOutcome& o) {
            std::vector<long> kept;
            for (std::size_t i = 0; i < o.levels.size(); ++i)
              if (o.levels[i] == lab::LevelStatus::kept_above) kept.push_back(static_cast<long>(i));
            return tuple_of(kept, PyLong_FromLong);
          },
          "Indices of the levels whose QP failed (they kept the solution of the levels above).")
      .def_prop_ro(
          "task_errors",
          [](const TickOutcome& o) {
            nb::dict errors;
            for (const auto& [name, error] : o.task_errors) errors[name.c_str()] = error;
            return errors;
          },
          "Norm of each stacked task's tracking error, by name.");

  nb::class_<lab::Kernel>(m, "Kernel")
      .def(
          "__init__",
          [](lab::Kernel* self, const std::string& model, const std::vector<ContactTuple>& contacts,
             const Eigen::VectorXd& torque_limits, const Eigen::VectorXd& lower,
             const Eigen::VectorXd& upper, double friction, double normal_min, double normal_max) {
            new (self) lab::Kernel(model, contact_specs(contacts), torque_limits, lower, upper,
                                   lab::ContactLimits{friction, normal_min, normal_max});
          },
          "model"_a, "contacts"_a, "torque_limits"_a, "lower"_a, "upper"_a, "friction"_a,
          "normal_min"_a, "normal_max"_a,
          "From pinocchio's Model.saveToString(), contacts as (name, frame, kind, radius, "
          "half_length, half_width), the actuated joints' torque and position limits and the "
          "contact limits.")
      .def_prop_ro("nq", [](const lab::Kernel& k) { return k.robot().nq; })
      .def_prop_ro("nv", [](const lab::Kernel& k) { return k.robot().nv; })
      .def_prop_ro("nf", [](const lab::Kernel& k) { return k.robot().nf; })
      .def_prop_ro("nx", [](const lab::Kernel& k) { return k.robot().nx; })
      .def_prop_ro("mass", [](const lab::Kernel& k) { return k.robot().mass; })
      .def_prop_ro("method", &lab::Kernel::method)
      .def(
          "frame_names", [](const lab::Kernel& k) { return k.robot().frame_names(); },
          "Names of the model's frames, in pinocchio order.")
      .def(
          "inertias", [](const lab::Kernel& k) { return k.robot().inertia_parameters(); },
          "Each joint's body inertia as pinocchio's 10 dynamic parameters (one row per joint).")
      .def("known_names", &lab::Kernel::known_names)
      .def("set_stack", &lab::Kernel::set_stack, "levels"_a)
      .def(
          "set_gains",
          [](lab::Kernel& k, const std::string& task, std::optional<double> kp,
             std::optional<double> kd, std::optional<double> weight) {
            const auto gains = k.set_gains(task, kp, kd, weight);
            return std::make_tuple(gains.kp, gains.kd, gains.weight);
          },
          "task"_a, "kp"_a = nb::none(), "kd"_a = nb::none(), "weight"_a = nb::none())
      .def("set_method", &lab::Kernel::set_method, "method"_a)
      .def("set_level_weight_ratio", &lab::Kernel::set_level_weight_ratio, "ratio"_a)
      .def(
          "set_contact_limits",
          [](lab::Kernel& k, double friction, double normal_min, double normal_max) {
            k.set_contact_limits({friction, normal_min, normal_max});
          },
          "friction"_a, "normal_min"_a, "normal_max"_a)
      .def("set_torque_limits", &lab::Kernel::set_torque_limits, "limits"_a)
      .def("set_joint_limits", &lab::Kernel::set_joint_limits, "lower"_a, "upper"_a)
      .def(
          "set_references",
          [](lab::Kernel& k, const Doubles& com, const Doubles& posture, double base_height,
             const Doubles& base_rotation, const Doubles& com_velocity,
             const Doubles& base_angular_velocity, const Flags& contact_active,
             const Doubles& normal_force_max, const Doubles& base_linear_velocity,
             const Doubles& foot_position, const Doubles& foot_velocity,
             const Doubles& foot_acceleration, const Doubles& surface_normal,
             const Doubles& force_weight, const Doubles& posture_velocity,
             const Doubles& posture_weight, const Doubles& com_acceleration) {
            assign_references(
                k,
                {com, posture, base_rotation, com_velocity, base_angular_velocity, normal_force_max,
                 base_linear_velocity, com_acceleration, foot_position, foot_velocity,
                 foot_acceleration, surface_normal, force_weight, posture_velocity, posture_weight},
                base_height, contact_active);
          },
          "com"_a, "posture"_a, "base_height"_a, "base_rotation"_a, "com_velocity"_a,
          "base_angular_velocity"_a, "contact_active"_a, "normal_force_max"_a,
          "base_linear_velocity"_a, "foot_position"_a, "foot_velocity"_a, "foot_acceleration"_a,
          "surface_normal"_a, "force_weight"_a, "posture_velocity"_a, "posture_weight"_a,
          "com_acceleration"_a,
          "The fields of References / WalkReferences (empty arrays for the walking fields a "
          "behaviour does not set); raises ValueError naming a field of the wrong size.")
      .def(
          "set_sole_references",
          [](lab::Kernel& k, const Doubles& sole_position, const Doubles& sole_rotation,
             const Flags& leg_swinging, const Doubles& leg_position, const Doubles& leg_velocity,
             const Doubles& leg_acceleration) {
            assign_sole_references(
                k, {sole_position, sole_rotation, leg_position, leg_velocity, leg_acceleration},
                leg_swinging);
          },
          "sole_position"_a, "sole_rotation"_a, "leg_swinging"_a, "leg_position"_a,
          "leg_velocity"_a, "leg_acceleration"_a,
          "The fields of SoleReferences (empty arrays for other references), before "
          "set_references, which checks every field's size.")
      .def("set_momentum_gain", &lab::Kernel::set_momentum_gain, "gain"_a,
           "The momentum task's K_h (6 x 9) from lab/controller/momentum.py; raises ValueError "
           "for another size or a non-finite entry.")
      .def("set_internal_force", &lab::Kernel::set_internal_force, "command"_a, "error"_a,
           "The internal-force task's F_int,cmd and error per pair of point feet in support "
           "(InternalForceTask.feedback); raises ValueError for a non-finite entry or sizes that "
           "do not match.")
      .def(
          "mirror_model",
          [](lab::Kernel& k, const nb::dict& arrays) {
            k.on_update = [mirror = ModelMirror(k.robot(), arrays)](
                              const lab::RobotModel& robot) mutable { mirror.fill(robot); };
          },
          "arrays"_a,
          "Arrays by name (q, v, M, h, Jc, Jc_dot_v, com, com_velocity, com_drift, Jcom, "
          "centroidal_map, base_rotation, contact_positions, contact_rotations) that every "
          "update fills in place, as RobotModel.update does; raises ValueError naming a missing "
          "or misshapen one.")
      .def("update", &lab::Kernel::update, "q"_a, "v"_a,
           "The model update alone (and the mirrored arrays, when given).")
      .def(
          "solve",
          [](lab::Kernel& k) {
            const lab::TickResult* result;
            {
              nb::gil_scoped_release release;
              result = &k.solve();
            }
            return tick_tuple(k, *result);
          },
          "Rows, method and torques at the state of the last update; the same tuple as tick.")
      .def(
          "tick_into",
          [](lab::Kernel& k, nb::handle refs, OutVector tau, OutVector x, std::optional<InVector> q,
             std::optional<InVector> v) {
            const auto& robot = k.robot();
            if (tau.size() != static_cast<std::size_t>(robot.na) ||
                x.size() != static_cast<std::size_t>(robot.nx))
              throw std::invalid_argument("tick_into: tau needs na entries and x nx");
            if (q.has_value() != v.has_value())
              throw std::invalid_argument("tick_into: give both q and v, or neither");
            // References first: bad ones raise before the update changes anything.
            reference_reader(k).read(k, refs);
            if (q)
              k.update(Eigen::Map<const Eigen::VectorXd>(q->data(), q->shape(0)),
                       Eigen::Map<const Eigen::VectorXd>(v->data(), v->shape(0)));
            // The GIL stays held: releasing it for a solve of tens of µs lets another thread
            // take it, and the loop's tick then waits for it to come back.
            const lab::TickResult& result = k.solve();
            TickOutcome outcome(k, result.solution);
            if (outcome.ok && !result.tau.allFinite()) {
              outcome.ok = false;
              outcome.message = "non-finite torques";
            }
            if (outcome.ok) {
              Eigen::Map<Eigen::VectorXd>(tau.data(), robot.na) = result.tau;
              Eigen::Map<Eigen::VectorXd>(x.data(), robot.nx) = result.solution.x;
            }
            return outcome;
          },
          "refs"_a, "tau"_a, "x"_a, "q"_a = nb::none(), "v"_a = nb::none(),
          "One crossing per tick: read the References object `refs`, update the model at (q, v) "
          "when given (else solve at the last update's state), solve, write τ and x = [q̈, F] "
          "into the given float64 arrays (when ok: finite τ) and return the TickOutcome.")
      .def_prop_ro(
          "seconds",
          [](const lab::Kernel& k) {
            return std::make_pair(k.update_seconds(), k.solve_seconds());
          },
          "Seconds the last update and the last solve took inside the kernel.")
      .def(
          "rows", [](lab::Kernel& k, const std::string& name) { return k.rows(name); }, "name"_a,
          "(A, b) of a task or (C, d) of a constraint at the last update, unweighted.")
      .def(
          "problem", [](lab::Kernel& k) { return problem_dict(k.build_problem()); },
          "The hierarchy problem of the current stack at the last update.")
      .def(
          "tick",
          [](lab::Kernel& k, const Eigen::Ref<const Eigen::VectorXd>& q,
             const Eigen::Ref<const Eigen::VectorXd>& v) {
            const lab::TickResult* result;
            {
              nb::gil_scoped_release release;  // the loop's other threads run meanwhile
              result = &k.tick(q, v);
            }
            return tick_tuple(k, *result);
          },
          "q"_a, "v"_a,
          "One tick: (tau, qdd, forces, ok, message, level statuses, level residuals, "
          "qp solves, task errors, level seconds).");
}
