// The Python face of the native behaviours (behaviour.hpp), shared by python.cpp and
// python_standing.cpp: the robot model's arrays and the Python references taken as the kernel's
// BehaviourModel and References, and `Binding<Core>`, the native tick of a Python behaviour whose
// twin is `Core`. Each binding file defines, in namespace lab, `load_state(Core&, behaviour, who)`
// (the Python object's state into the twin, the same names) and `write_state(now, before,
// behaviour)` (the state a tick changed back into it), found by argument-dependent lookup.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>

#include <string>
#include <utility>
#include <vector>

#include "behaviours/behaviour.hpp"
#include "behaviours/native_behaviour.hpp"

namespace lab::binding {

namespace nb = nanobind;

using Doubles = nb::ndarray<double, nb::c_contig, nb::device::cpu>;
using Flags = nb::ndarray<bool, nb::c_contig, nb::device::cpu>;
using Command = nb::ndarray<const double, nb::shape<3>, nb::c_contig, nb::device::cpu>;
using Touching = nb::ndarray<const bool, nb::shape<-1>, nb::c_contig, nb::device::cpu>;

/// `owner.name` as a C-contiguous array of `size` entries (taken in place, never copied);
/// raises ValueError naming the behaviour (`who`) and the field otherwise.
template <typename Array>
Array field(nb::handle owner, const char* name, std::size_t size, const std::string& who) {
  Array array;
  if (!nb::try_cast(owner.attr(name), array, false) || array.size() != size)
    throw nb::value_error((who + ": " + name + " must be a C-contiguous array of " +
                           std::to_string(size) + " entries of its type")
                              .c_str());
  return array;
}

inline Eigen::Vector3d vector3(nb::handle owner, const char* name, const std::string& who) {
  return Eigen::Map<const Eigen::Vector3d>(field<Doubles>(owner, name, 3, who).data());
}

/// The robot model's arrays a behaviour reads (RobotModel.arrays(), taken in place).
struct ModelArrays {
  Doubles q, v, base_rotation, contact_positions, contact_rotations, contact_jacobian, com,
      com_velocity, centroidal_map;
  double mass = 0.0;
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();
  std::size_t contacts = 0;

  void load(nb::handle robot, const std::string& who) {
    const std::size_t nq = nb::len(nb::object(robot.attr("q")));
    const std::size_t nv = nb::len(nb::object(robot.attr("v")));
    contacts = nb::len(nb::object(robot.attr("contacts")));
    if (nq < 7) throw nb::value_error((who + ": the model needs a floating base").c_str());
    q = field<Doubles>(robot, "q", nq, who);
    v = field<Doubles>(robot, "v", nv, who);
    base_rotation = field<Doubles>(robot, "base_rotation", 9, who);
    contact_positions = field<Doubles>(robot, "contact_positions", 3 * contacts, who);
    contact_rotations = field<Doubles>(robot, "contact_rotations", 9 * contacts, who);
    const std::size_t nf = nb::len(nb::object(robot.attr("Jc")));
    contact_jacobian = field<Doubles>(robot, "Jc", nf * nv, who);
    com = field<Doubles>(robot, "com", 3, who);
    com_velocity = field<Doubles>(robot, "com_velocity", 3, who);
    centroidal_map = field<Doubles>(robot, "centroidal_map", 6 * nv, who);
    mass = nb::cast<double>(robot.attr("mass"));
    gravity = vector3(robot, "gravity", who);
  }

  BehaviourModel view() const {
    const auto nq = static_cast<Eigen::Index>(q.size()), nv = static_cast<Eigen::Index>(v.size());
    const auto n = static_cast<Eigen::Index>(contacts);
    return {
        Eigen::Map<const Eigen::VectorXd>(q.data(), nq),
        Eigen::Map<const Eigen::VectorXd>(v.data(), nv),
        Eigen::Map<const RowMatrix3>(base_rotation.data()),
        Eigen::Map<const RowMatrixX3>(contact_positions.data(), n, 3),
        Eigen::Map<const RowMatrixX3>(contact_rotations.data(), 3 * n, 3),
        Eigen::Map<const RowMatrixX>(contact_jacobian.data(),
                                     static_cast<Eigen::Index>(contact_jacobian.size()) / nv, nv),
        Eigen::Map<const Eigen::Vector3d>(com.data()),
        Eigen::Map<const Eigen::Vector3d>(com_velocity.data()),
        Eigen::Map<const RowMatrixX>(centroidal_map.data(), 6, nv),
        mass,
        gravity};
  }
};

/// The Python references object's fields, as kReferenceFields lists them, copied into a
/// lab::References on load and written back in place after each native tick (only behaviours
/// write references, and a Python tick of the behaviour reloads them).
class ReferenceArrays {
 public:
  void load(nb::handle refs, const std::string& who) {
    refs_ = nb::borrow(refs);
    values_ = References{};
    doubles_.clear();
    flags_.clear();
    has_height_ = has_rotation_ = false;
    nb::object names = nb::module_::import_("dataclasses").attr("fields")(refs);
    for (nb::handle declared : names) {
      const std::string name = nb::cast<std::string>(declared.attr("name"));
      const ReferenceField* found = nullptr;
      for (const ReferenceField& f : kReferenceFields)
        if (name == f.name) found = &f;
      if (found == nullptr)
        throw nb::value_error((who + ": the references' field " + name +
                               " is not in the kernel's layout (cpp/references.hpp)")
                                  .c_str());
      // The hands' targets are the session's (hand_targets.py writes them before each tick), not
      // the behaviour's: written back from this load, they would pin every hand to the target it
      // had when the behaviour started.
      if (name.rfind("hand_", 0) == 0) continue;
      bool stored;
      if (found->type == FieldType::number) {
        height_ = nb::cast<double>(refs.attr(found->name));
        stored = found->set_doubles(values_, &height_, 1);
        has_height_ = true;
      } else if (found->type == FieldType::flags) {
        Flags a;
        if (!nb::try_cast(refs.attr(found->name), a, false))
          throw nb::value_error((who + ": " + name + " must be a C-contiguous bool array").c_str());
        stored = found->set_flags(values_, a.data(), static_cast<Eigen::Index>(a.size()));
        if (stored) flags_.push_back({a, &flag_source(name)});
      } else {
        // Taken in place, to be written back after each tick: an array that is not C-contiguous
        // float64 (pinocchio's rotation matrices are Fortran-ordered) is replaced by such a copy.
        Doubles a;
        if (!nb::try_cast(refs.attr(found->name), a, false)) {
          refs.attr(found->name) = nb::module_::import_("numpy").attr("ascontiguousarray")(
              refs.attr(found->name), "float64");
          if (!nb::try_cast(refs.attr(found->name), a, false))
            throw nb::value_error((who + ": " + name + " must be a float64 array").c_str());
        }
        stored = found->set_doubles(values_, a.data(), static_cast<Eigen::Index>(a.size()));
        if (stored && name == "base_rotation") {
          rotation_ = a;
          has_rotation_ = true;
        } else if (stored && a.size() > 0) {
          doubles_.push_back({a, source(name)});
        }
      }
      if (!stored)
        throw nb::value_error((who + ": " + name + " needs shape (" + found->shape + ")").c_str());
    }
  }

  References& values() { return values_; }

  /// This tick's references into the Python arrays, in place (the base height by attribute).
  void write_back() {
    for (auto& [array, in] : doubles_) std::copy(in, in + array.size(), array.data());
    if (has_rotation_) Eigen::Map<RowMatrix3>(rotation_.data()) = values_.base_rotation;
    for (auto& [array, in] : flags_) std::copy(in->data(), in->data() + array.size(), array.data());
    if (has_height_ && values_.base_height != height_) {
      height_ = values_.base_height;
      refs_.attr("base_height") = height_;
    }
  }

 private:
  /// Where References stores a float field other than the base rotation (column-major here);
  /// its storage stays put: the behaviours assign fields of their loaded sizes.
  const double* source(const std::string& name) {
    References& r = values_;
    const std::pair<const char*, const double*> vectors[] = {
        {"com", r.com.data()},
        {"com_velocity", r.com_velocity.data()},
        {"com_acceleration", r.com_acceleration.data()},
        {"base_angular_velocity", r.base_angular_velocity.data()},
        {"base_linear_velocity", r.base_linear_velocity.data()},
        {"posture", r.posture.data()},
        {"normal_force_max", r.normal_force_max.data()},
        {"foot_position", r.foot_position.data()},
        {"foot_velocity", r.foot_velocity.data()},
        {"foot_acceleration", r.foot_acceleration.data()},
        {"surface_normal", r.surface_normal.data()},
        {"force_weight", r.force_weight.data()},
        {"posture_velocity", r.posture_velocity.data()},
        {"posture_weight", r.posture_weight.data()},
        {"sole_position", r.sole_position.data()},
        {"sole_rotation", r.sole_rotation.data()},
        {"leg_position", r.leg_position.data()},
        {"leg_velocity", r.leg_velocity.data()},
        {"leg_acceleration", r.leg_acceleration.data()},
    };
    for (const auto& [field, data] : vectors)
      if (name == field) return data;
    throw nb::value_error(("native behaviour: no float field " + name).c_str());
  }

  const Eigen::Array<bool, Eigen::Dynamic, 1>& flag_source(const std::string& name) const {
    if (name == "contact_active") return values_.contact_active;
    if (name == "swing_tracked") return values_.swing_tracked;
    if (name == "leg_swinging") return values_.leg_swinging;
    throw nb::value_error(("native behaviour: no flag field " + name).c_str());
  }

  nb::object refs_;
  References values_;
  std::vector<std::pair<Doubles, const double*>> doubles_;
  std::vector<std::pair<Flags, const Eigen::Array<bool, Eigen::Dynamic, 1>*>> flags_;
  Doubles rotation_;
  double height_ = 0.0;
  bool has_height_ = false, has_rotation_ = false;
};

/// The native tick of a Python behaviour whose twin is `Core`: `update` loads the Python
/// object's state, the references and the model's arrays when told the state changed (or on a
/// new robot model), runs Core::update (the NativeBehaviour interface) and writes the references
/// and the state that changed back to the Python objects, so that the Python behaviour stays
/// current and can run the next tick itself.
template <class Core>
class Binding : public TickedBehaviour {
 public:
  explicit Binding(std::string who) : who_(std::move(who)) {}

  void update(nb::handle behaviour, nb::handle robot, double t, Command command, Touching touching,
              bool reload) {
    tick(behaviour, robot, t, command.data(), touching.data(), touching.shape(0), reload);
  }

  /// The server's native tick's entry (native_behaviour.hpp): `update` on raw arrays.
  void tick(nb::handle behaviour, nb::handle robot, double t, const double* command,
            const bool* touching, std::size_t feet, bool reload) override {
    if (reload || !robot.is(robot_)) {
      model_.load(robot, who_);
      refs_.load(behaviour.attr("references"), who_);
      load_state(core_, behaviour, who_);
      robot_ = nb::borrow(robot);
    }
    if (feet != model_.contacts)
      throw nb::value_error((who_ + ": `touching` needs one flag per contact").c_str());
    before_ = core_;  // assigned, not constructed: its vectors keep their storage, no allocation
    touching_ = Eigen::Map<const Eigen::Array<bool, Eigen::Dynamic, 1>>(
        touching, static_cast<Eigen::Index>(feet));
    NativeBehaviour& native = core_;  // the one interface (behaviour.hpp)
    native.update(t, model_.view(), Eigen::Map<const Eigen::Vector3d>(command), touching_,
                  refs_.values());
    refs_.write_back();
    write_state(core_, before_, behaviour);
  }

 private:
  std::string who_;
  Core core_;
  Core before_;  // core_ as the last tick found it, for write_state
  ModelArrays model_;
  ReferenceArrays refs_;
  Eigen::Array<bool, Eigen::Dynamic, 1> touching_;
  nb::object robot_;
};

/// Binds `Binding<Core>` as `_kernel.<name>`; `who` names it in errors ("native walking").
template <class Core>
void bind(nb::module_& m, const char* name, const char* who, const char* doc) {
  nb::class_<Binding<Core>, TickedBehaviour>(m, name, doc)
      .def("__init__", [who](Binding<Core>* self) { new (self) Binding<Core>(who); })
      .def("update", &Binding<Core>::update, nb::arg("behaviour"), nb::arg("robot"), nb::arg("t"),
           nb::arg("command"), nb::arg("touching"), nb::arg("reload"),
           "The behaviour's update in C++ on the model's arrays; `reload`: the Python object's "
           "state changed since the last call (a Python tick, configure, request) and is read "
           "first. The references are written in place, the state back to the Python object.");
}

}  // namespace lab::binding
