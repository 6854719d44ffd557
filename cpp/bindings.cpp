// lab._kernel: the Python face of the native kernel (lab/controller/native.py wraps it).
// Over 400 lines: one nanobind module's definitions, a block per bound class, with nothing
// else in the file (the hierarchy, behaviours and realism bind themselves in their python.cpp).
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
#include <type_traits>

#include "behaviours/python.hpp"  // leg_posture_velocity: the walking behaviour's hot part
#include "controller.hpp"
#include "estimation/python.hpp"
#include "frames.hpp"        // FramePlacements: the drawing state's frames
#include "tick_outcome.hpp"  // TickOutcome, read_references, bind_server_tick
#if __has_include("hierarchy/python.hpp")
#include "hierarchy/python.hpp"  // solve_hierarchy: the native methods on a given problem
#define LAB_BIND_HIERARCHY
#endif
#include "realism/python.hpp"  // RealismLayer: sensors, delays, actuators (lab/realism)

namespace nb = nanobind;
using namespace nb::literals;

using lab::TickOutcome;

namespace {

using Doubles = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
using Flags = nb::ndarray<const bool, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using InVector = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using ContactTuple = std::tuple<std::string, std::string, std::string, double, double, double>;

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

/// A C-contiguous array of T (float64 or bool) seen through the buffer protocol, without a
/// copy: data is null when the object exports no such buffer (or no writable one when asked).
/// nanobind's ndarray caster asks numpy's __dlpack__ instead (a method call, a capsule and two
/// allocations per import): a tick paid that for τ, x, q and v, and bench_tsid's references, a
/// new object each tick, for each of their 15 fields. The data stays valid while the caller
/// holds the object (numpy cannot resize an array another object refers to).
template <typename T>
struct BufferData {
  T* data = nullptr;
  Eigen::Index size = 0;
  int ndim = 0;

  BufferData(nb::handle object, bool writable) {
    Py_buffer view;
    const int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(object.ptr(), &view, flags) != 0) {
      PyErr_Clear();
      return;
    }
    const char* format = view.format ? view.format : "B";
    if (*format == '@' || *format == '=' || *format == '<') ++format;  // native: little-endian
    if (view.itemsize == static_cast<Py_ssize_t>(sizeof(T)) && format[1] == '\0' &&
        format[0] == (std::is_same_v<std::remove_const_t<T>, bool> ? '?' : 'd')) {
      data = static_cast<T*>(view.buf);
      size = static_cast<Eigen::Index>(view.len / view.itemsize);
      ndim = view.ndim;
    }
    PyBuffer_Release(&view);
  }
};

/// Reads a references object's fields straight from Python, as lab::kReferenceFields lists them:
/// an array seen on the last read is read through the pointer already taken (so a behaviour's
/// in-place change shows), one the behaviour replaced is taken anew (BufferData; another type
/// than float64 or bool, or a list, is converted by nanobind, a copy each read). A field the
/// object's class does not have (a plain References has no walking or sole fields) reads as empty.
class ReferenceReader {
 public:
  static constexpr std::size_t kFields = lab::kReferenceFields.size();

  ReferenceReader() {
    for (std::size_t i = 0; i < kFields; ++i)  // interned: a lookup by C string builds the str
      names_[i] = nb::steal(PyUnicode_InternFromString(lab::kReferenceFields[i].name));
  }

  /// Copy the fields of `refs` into the kernel's references; raises ValueError naming a field
  /// of the wrong type or size.
  void read(lab::Kernel& k, nb::handle refs) {
    nb::handle type = refs.type();
    if (!type.is(type_)) {  // a new class: which of the fields does it have?
      type_ = nb::borrow(type);
      for (std::size_t i = 0; i < kFields; ++i) present_[i] = nb::hasattr(refs, names_[i]);
    }
    lab::References& out = k.references();
    for (std::size_t i = 0; i < kFields; ++i) {
      const lab::ReferenceField& field = lab::kReferenceFields[i];
      bool stored;
      if (field.type == lab::FieldType::number) {
        if (!present_[i]) missing(field);
        const double value = nb::cast<double>(refs.attr(names_[i]));
        stored = field.set_doubles(out, &value, 1);
      } else if (!present_[i]) {
        seen_[i] = nb::object();
        stored = field.type == lab::FieldType::flags ? field.set_flags(out, nullptr, 0)
                                                     : field.set_doubles(out, nullptr, 0);
      } else {
        nb::object value = refs.attr(names_[i]);
        const bool flags = field.type == lab::FieldType::flags;
        if (!(seen_[i].is_valid() && value.is(seen_[i]))) {
          if (flags)
            take<Flags>(value, field.name, i, flags_[i]);
          else
            take<Doubles>(value, field.name, i, doubles_[i]);
        }
        stored = flags ? field.set_flags(out, static_cast<const bool*>(data_[i]), sizes_[i])
                       : field.set_doubles(out, static_cast<const double*>(data_[i]), sizes_[i]);
      }
      if (!stored)
        throw std::invalid_argument(std::string("references: ") + field.name + " needs shape (" +
                                    field.shape + ")");
    }
    k.check_references();
  }

 private:
  [[noreturn]] static void missing(const lab::ReferenceField& field) {
    throw std::invalid_argument(std::string("references: no field ") + field.name);
  }

  /// Field i's data from `value`: its own buffer when it is a C-contiguous array of the field's
  /// type (kept in seen_[i]: later reads see it in place), else nanobind's converted copy in
  /// `converted` (seen_[i] cleared: converted again each read).
  template <typename Array>
  void take(const nb::object& value, const char* name, std::size_t i, Array& converted) {
    const BufferData<const std::remove_const_t<typename Array::Scalar>> buffer(value, false);
    if (buffer.data && (buffer.ndim == 1 || !std::is_same_v<Array, Flags>)) {
      seen_[i] = value;
      data_[i] = buffer.data;
      sizes_[i] = buffer.size;
      converted = Array();
      return;
    }
    seen_[i] = nb::object();
    if (!nb::try_cast(value, converted, true))
      throw std::invalid_argument(std::string("references: ") + name +
                                  " is not an array of the right type");
    data_[i] = converted.data();
    sizes_[i] = static_cast<Eigen::Index>(converted.size());
  }

  nb::object type_;
  std::array<bool, kFields> present_{};
  std::array<nb::object, kFields> names_, seen_;
  std::array<const void*, kFields> data_{};
  std::array<Eigen::Index, kFields> sizes_{};
  std::array<Doubles, kFields> doubles_;
  std::array<Flags, kFields> flags_;
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
    vector(M_) = robot.M.reshaped();  // symmetric: its column-major entries are its row-major ones
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

/// A float64 vector argument without a copy when it is one (BufferData), else nanobind's
/// conversion into `converted` (a list, another dtype), which raises as its caster does.
Eigen::Map<const Eigen::VectorXd> vector_of(nb::handle object, InVector& converted) {
  const BufferData<const double> buffer(object, false);
  if (buffer.data && buffer.ndim == 1) return {buffer.data, buffer.size};
  converted = nb::cast<InVector>(object);
  return {converted.data(), static_cast<Eigen::Index>(converted.shape(0))};
}

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

template <typename Values, typename Item>
nb::tuple tuple_of(const Values& values, Item&& item) {
  nb::tuple out = nb::steal<nb::tuple>(PyTuple_New(static_cast<Py_ssize_t>(values.size())));
  for (std::size_t i = 0; i < values.size(); ++i)
    PyTuple_SET_ITEM(out.ptr(), static_cast<Py_ssize_t>(i), item(values[i]));
  return out;
}

/// A bool array's entries as Eigen's.
Eigen::Array<bool, Eigen::Dynamic, 1> flags_of(const Flags& flags) {
  Eigen::Array<bool, Eigen::Dynamic, 1> out(static_cast<Eigen::Index>(flags.shape(0)));
  for (std::size_t i = 0; i < flags.shape(0); ++i)
    out(static_cast<Eigen::Index>(i)) = flags.data()[i];
  return out;
}

}  // namespace

void lab::read_references(lab::Kernel& kernel, nb::handle refs) {
  reference_reader(kernel).read(kernel, refs);
}

NB_MODULE(_kernel, m) {
  m.doc() = "The native controller kernel: lab/controller's tick in C++ (see cpp/README.md).";

  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const lab::UnknownName& e) {
      PyErr_SetString(PyExc_KeyError, e.what());
    }
  });

  m.attr("nullspace_max_projections") = lab::kMaxProjections;
  m.attr("has_solvers") =
#ifdef LAB_HAVE_HIERARCHY_SOLVERS
      true;
#else
      false;
#endif

#ifdef LAB_BIND_HIERARCHY
  lab::bind_hierarchy(m);
#endif
  lab::bind_realism(m);
  lab::bind_estimation(m);
  lab::bind_behaviours(m);

  m.def(
      "reference_fields",
      [] {
        std::vector<std::tuple<std::string, std::string, std::string, std::string>> fields;
        for (const auto& field : lab::kReferenceFields) {
          const char* type = field.type == lab::FieldType::number    ? "float"
                             : field.type == lab::FieldType::doubles ? "float64"
                                                                     : "bool";
          fields.emplace_back(field.name, field.declared_by, type, field.shape);
        }
        return fields;
      },
      "The references' fields the kernel reads (cpp/references.hpp kReferenceFields): (name, "
      "declaring class, type: float, float64 or bool, shape in the robot's sizes n, na and h).");
  lab::bind_frame_placements(m);

  nb::class_<TickOutcome>(m, "TickOutcome",
                          "What a tick_into reported besides τ and x (a copy: it stays the "
                          "tick's own).")
      .def_ro("ok", &TickOutcome::ok)
      .def_ro("message", &TickOutcome::message)
      .def_ro("qp_solves", &TickOutcome::qp_solves)
      .def_ro("capped", &TickOutcome::capped,
              "nullspace: whether an active-set search stopped at its cap (kMaxProjections).")
      .def_ro("projections", &TickOutcome::projections,
              "nullspace: the hierarchy solves its active-set searches made.")
      .def_prop_ro(
          "active_sets",
          [](const TickOutcome& o) {
            nb::list searches;
            for (const auto& search : o.active_sets) {
              nb::list levels;
              for (const auto& rows : search)
                levels.append(nb::cast(Eigen::Array<bool, Eigen::Dynamic, 1>(rows)));
              searches.append(levels);
            }
            return nb::tuple(searches);
          },
          "nullspace: the active rows of each level's C where each search stopped (a tuple of "
          "lists of bool arrays, as HierarchySolution.active_sets).")
      .def_prop_ro("levels",
                   [](const TickOutcome& o) {
                     return tuple_of(o.levels, [](lab::LevelStatus s) {
                       return PyUnicode_InternFromString(lab::level_status_name(s));
                     });
                   })
      .def_prop_ro("residuals",
                   [](const TickOutcome& o) { return tuple_of(o.residuals, PyFloat_FromDouble); })
      .def_ro("internal_force_sensed", &TickOutcome::internal_force_sensed,
              "The internal force's F_int,act per pair at this tick's rows (Kim eq. 12).")
      .def_ro("internal_force_command", &TickOutcome::internal_force_command,
              "The internal force's F_int,cmd per pair at this tick's rows (Kim eq. 12).")
      .def_prop_ro(
          "violations",
          [](const TickOutcome& o) {
            return tuple_of(o.violations, [](const std::string& line) {
              return PyUnicode_FromStringAndSize(line.data(), static_cast<Py_ssize_t>(line.size()));
            });
          },
          "wbosc: each constraint of the stack violated at x, one line.")
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
            auto specs = contact_specs(contacts);
            // pinocchio's deserialization and the set-up: C++ alone, the loop runs meanwhile
            nb::gil_scoped_release release;
            new (self) lab::Kernel(model, std::move(specs), torque_limits, lower, upper,
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
      .def_prop_ro("formulation", &lab::Kernel::formulation)
      .def("set_formulation", &lab::Kernel::set_formulation, "formulation"_a,
           "nullspace's optimization vector (qdd_force, full, qdd_tau, sequential); KeyError for "
           "another name. A new one starts the next search cold.")
      .def("forget_last_solution", &lab::Kernel::forget_last_solution,
           "Start the next nullspace search cold (after a reset: the last tick's active rows and "
           "x belong to a state that is gone).")
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
          [](lab::Kernel& k, nb::handle refs) { reference_reader(k).read(k, refs); }, "refs"_a,
          "Copy a References (WalkReferences, SoleReferences) object's fields into the kernel, "
          "as reference_fields() lists them; raises ValueError naming a field of the wrong "
          "type or size.")
      .def("set_momentum_gain", &lab::Kernel::set_momentum_gain, "gain"_a,
           "The momentum task's K_h (6 x 9) from lab/controller/momentum.py; raises ValueError "
           "for another size or a non-finite entry.")
      .def(
          "set_momentum_schedule",
          [](lab::Kernel& k, std::optional<nb::callable> schedule, double arm_tolerance) {
            std::function<void(long)> ask;
            if (schedule)  // called inside a tick, which may have let the GIL go; the kernel
              ask = [call = *schedule, kernel = &k](long blended) {  // owns this: outlives it
                nb::gil_scoped_acquire gil;
                const nb::tuple out = nb::cast<nb::tuple>(call(blended));
                if (out.size() != 4)
                  throw std::invalid_argument(
                      "momentum schedule: return (gain, active, arms, blend)");
                kernel->set_momentum_gain(nb::cast<Eigen::MatrixXd>(out[0]));
                if (out[1].is_none()) {
                  kernel->release_momentum_gain();
                  return;
                }
                kernel->hold_momentum_gain(flags_of(nb::cast<Flags>(out[1])),
                                           nb::cast<Eigen::MatrixXd>(out[2]));
                if (out[3].is_none()) return;
                const nb::tuple blend = nb::cast<nb::tuple>(out[3]);
                if (blend.size() != 4)
                  throw std::invalid_argument(
                      "momentum schedule: a blend is (from, to, step, length)");
                kernel->blend_momentum_gain(nb::cast<Eigen::MatrixXd>(blend[0]),
                                            nb::cast<Eigen::MatrixXd>(blend[1]),
                                            nb::cast<long>(blend[2]), nb::cast<long>(blend[3]));
              };
            k.set_momentum_schedule(std::move(ask), arm_tolerance);
          },
          "schedule"_a.none(), "arm_tolerance"_a,
          "The momentum task's gain schedule, asked inside a tick whenever no held K_h stays "
          "(another contact configuration, or an arm p_i - c moved more than arm_tolerance, m), "
          "with the interpolation steps the kernel made since the last ask: a callable "
          "returning (K_h, the contact flags, the arms, one row per contact in support, and "
          "the blend (from, to, step, length) the kernel steps while held, or None) to hold "
          "its target at, or (K_h, None, None, None). None: K_h only from set_momentum_gain. "
          "A Python error it raises leaves the tick.")
      .def(
          "hold_momentum_gain",
          [](lab::Kernel& k, Flags active, const Eigen::MatrixXd& arms) {
            k.hold_momentum_gain(flags_of(active), arms);
          },
          "active"_a, "arms"_a,
          "Hold the current K_h as settled for the contacts `active` (bool per contact) at the "
          "arms p_i - c (one row of 3 per contact in support) its design read.")
      .def("take_momentum_blend_steps", &lab::Kernel::take_momentum_blend_steps,
           "The interpolation steps the kernel made since the schedule was last asked (or "
           "this was last called), counted from zero again.")
      .def("release_momentum_gain", &lab::Kernel::release_momentum_gain,
           "The next tick asks the momentum schedule again.")
      .def("set_internal_force", &lab::Kernel::set_internal_force, "reference"_a, "source"_a,
           "The internal-force task's F_int,ref (N) and sensed source (contacts or torques); "
           "raises ValueError for a non-finite reference or another source.")
      .def("set_hands", &lab::Kernel::set_hands, "frames"_a,
           "joints"_a = std::vector<std::string>{},
           "The frames the hands task moves, one hand each, in the order of the references' "
           "hand rows, and the joints each may use ('all' or 'arm'; empty: all); raises "
           "ValueError naming a frame the model lacks or a bad option.")
      .def(
          "set_sensing",
          [](lab::Kernel& k, const Doubles& foot_forces, const InVector& applied_torques) {
            k.set_sensing(
                Eigen::Map<const Eigen::VectorXd>(foot_forces.data(),
                                                  static_cast<Eigen::Index>(foot_forces.size())),
                Eigen::Map<const Eigen::VectorXd>(
                    applied_torques.data(), static_cast<Eigen::Index>(applied_torques.size())));
          },
          "foot_forces"_a, "applied_torques"_a,
          "What the sensors measured over the last step, for the internal force's feedback (Kim "
          "eqs. 12-13): the terrain's force on each foot (n_contacts x 3, N, world) and the joint "
          "torques applied (N m); raises ValueError for other sizes or non-finite entries.")
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
          [](lab::Kernel& k, nb::handle refs, nb::handle tau_array, nb::handle x_array,
             nb::handle q_array, nb::handle v_array) {
            const auto& robot = k.robot();
            const BufferData<double> tau(tau_array, true), x(x_array, true);
            if (!tau.data || tau.ndim != 1 || tau.size != robot.na || !x.data || x.ndim != 1 ||
                x.size != robot.nx)
              throw std::invalid_argument(
                  "tick_into: tau and x must be writable C-contiguous float64 vectors of na and "
                  "nx entries");
            if (q_array.is_none() != v_array.is_none())
              throw std::invalid_argument("tick_into: give both q and v, or neither");
            const bool state = !q_array.is_none();
            InVector q_copy, v_copy;
            const auto q =
                state ? vector_of(q_array, q_copy) : Eigen::Map<const Eigen::VectorXd>(nullptr, 0);
            const auto v =
                state ? vector_of(v_array, v_copy) : Eigen::Map<const Eigen::VectorXd>(nullptr, 0);
            // References first: bad ones raise before the update changes anything.
            reference_reader(k).read(k, refs);
            if (state) k.update(q, v);
            // The GIL stays held: releasing it for a solve of tens of µs lets another thread
            // take it, and the loop's tick then waits for it to come back.
            const lab::TickResult& result = k.solve();
            TickOutcome outcome(k, result);
            if (outcome.ok) {
              Eigen::Map<Eigen::VectorXd>(tau.data, robot.na) = result.tau;
              Eigen::Map<Eigen::VectorXd>(x.data, robot.nx) = result.solution.x;
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
            return std::make_tuple(k.update_seconds(), k.rows_seconds(),
                                   k.solve_seconds() - k.rows_seconds());
          },
          "Seconds the last tick's stages took inside the kernel: the model update, the rows "
          "(with the references' check) and the rest of the solve (hierarchy method, torques).")
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

#ifdef LAB_HAVE_MUJOCO
  lab::bind_server_tick(m);  // after Kernel and TickOutcome, which it takes and returns
  m.attr("has_server_tick") = true;
#else
  m.attr("has_server_tick") = false;
#endif
}
