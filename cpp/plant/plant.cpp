// lab._plant: the per-tick exchange of lab/world/plant.py (MujocoPlant) with MuJoCo in one
// crossing each: the state check, the state in pinocchio conventions, the torques, the step,
// and the feet's contacts with the terrain. It works on the MjModel and MjData the Python plant
// built (their `_address`), through the MuJoCo C API of the same wheel (its headers and
// libmujoco), and mirrors plant.py's functions of the same names; plant.py keeps its Python
// path for when this module is not built, and tests/kernel/test_plant_native.py holds the two
// equal. And a copy of an MjModel made without the GIL (`copy_model`, for a robot switch built
// beside the loop: lab/world/compiled.py).
#include <mujoco/mujoco.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/tuple.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "plant/mujoco_step.hpp"

namespace nb = nanobind;
using namespace nb::literals;

namespace {

using Indices = nb::ndarray<const long long, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Doubles = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Array = nb::ndarray<nb::numpy, double, nb::ndim<1>>;

/// The struct behind a MuJoCo Python object (MjModel, MjData): its `_address`.
template <typename T>
T* address_of(const nb::handle& object) {
  return reinterpret_cast<T*>(nb::cast<std::uintptr_t>(object.attr("_address")));
}

std::vector<int> as_ints(const Indices& a) { return {a.data(), a.data() + a.size()}; }

/// A new 1-D float64 numpy array of n entries (owned by Python).
Array new_array(std::size_t n, double*& data) {
  data = new double[n];
  nb::capsule owner(data, [](void* p) noexcept { delete[] static_cast<double*>(p); });
  return Array(data, {n}, owner);
}

/// lab::MujocoStep's calls one by one, each a crossing (mujoco_step.hpp); the GIL stays held, as
/// in the kernel's solve.
class PlantStep {
 public:
  PlantStep(nb::object mj_model, nb::object mj_data, const Indices& q_order, const Indices& v_order,
            const Indices& terrain, const Indices& foot_of_geom, int n_feet)
      : model_object_(std::move(mj_model)),
        data_object_(std::move(mj_data)),
        step_(address_of<const mjModel>(model_object_), address_of<mjData>(data_object_),
              as_ints(q_order), as_ints(v_order), as_ints(terrain), as_ints(foot_of_geom), n_feet) {
  }

  /// The time comes along with check's test because reading MjData.time from Python costs more
  /// than this whole call.
  double check() const { return step_.check(); }

  nb::tuple state() const {
    double *q, *v;
    Array q_array = new_array(static_cast<std::size_t>(step_.nq()), q);
    Array v_array = new_array(static_cast<std::size_t>(step_.nv()), v);
    step_.state(q, v);
    return nb::make_tuple(q_array, v_array);
  }

  void set_torques(const Doubles& tau) {
    const int nu = step_.nu();
    bool ok = static_cast<int>(tau.size()) == nu;
    for (int i = 0; ok && i < nu; ++i) ok = std::isfinite(tau(i));
    if (!ok)
      throw std::invalid_argument("set_torques needs " + std::to_string(nu) +
                                  " finite torques (N m)");
    step_.set_torques(tau.data());
  }

  double step() { return step_.step(); }

  Array foot_normal_forces() const {
    double* out;
    Array array = new_array(static_cast<std::size_t>(step_.n_feet()), out);
    step_.foot_normal_forces(out);
    return array;
  }

  void foot_forces(nb::ndarray<double, nb::shape<-1, 3>, nb::c_contig, nb::device::cpu> out) const {
    if (out.shape(0) != static_cast<std::size_t>(step_.n_feet()))
      throw std::invalid_argument("foot_forces needs an array of " +
                                  std::to_string(step_.n_feet()) + " x 3");
    step_.foot_forces(out.data());
  }

  bool non_foot_ground_contact() const { return step_.non_foot_ground_contact(); }

 private:
  nb::object model_object_, data_object_;  // keep the structs alive
  lab::MujocoStep step_;
};

/// A new mujoco.MjModel, a copy of `mj_model` made by mj_copyModel with the GIL released (the
/// Python binding's copy keeps it: Solo12's 7.4 MB, 1.3 ms of CPU and its page faults, the
/// longest GIL hold of a switch back to a kept robot). The caller's reference keeps the source
/// alive, and it must not change meanwhile (a kept world's model is never run or handed out).
/// Who frees the new struct: this function until its address is a Python integer, then MuJoCo's
/// binding from the call to `MjModel._from_model_ptr` on (the way MuJoCo's own spec module
/// wraps a model it compiled): it takes the pointer without copying it again, and its wrapper's
/// capsule frees it with mj_deleteModel, also when the wrapper's construction fails partway,
/// so it is never freed here after that call (tests/world/test_compiled.py). A private name,
/// but this module is used only with the MuJoCo it was built against (plant.py's check).
nb::object copy_model(const nb::handle& mj_model) {
  const mjModel* source = address_of<const mjModel>(mj_model);
  nb::object wrap = nb::module_::import_("mujoco").attr("MjModel").attr("_from_model_ptr");
  mjModel* copy;
  {
    nb::gil_scoped_release released;
    copy = mj_copyModel(nullptr, source);
  }
  if (copy == nullptr) throw std::runtime_error("mj_copyModel could not copy the model");
  nb::object address;
  try {
    address = nb::int_(reinterpret_cast<std::uintptr_t>(copy));
  } catch (...) {
    mj_deleteModel(copy);
    throw;
  }
  return wrap(address);
}

}  // namespace

NB_MODULE(_plant, m) {
  m.doc() = "The plant's per-tick exchange with MuJoCo in C (lab/world/plant.py; cpp/README.md).";
  m.attr("mujoco_version") = mj_versionString();
  m.def("copy_model", &copy_model, "mj_model"_a,
        "A copy of the MjModel (a new mujoco.MjModel), made with the GIL released.");
  nb::class_<PlantStep>(m, "PlantStep")
      .def(nb::init<nb::object, nb::object, const Indices&, const Indices&, const Indices&,
                    const Indices&, int>(),
           "mj_model"_a, "mj_data"_a, "q_order"_a, "v_order"_a, "terrain"_a, "foot_of_geom"_a,
           "n_feet"_a,
           "On the plant's MjModel and MjData: qpos and qvel indices of pinocchio's q and v, "
           "per geom whether it is terrain (1) and which foot it is (or -1), the foot count.")
      .def("check", &PlantStep::check,
           "The sim time if the state is valid, else -1 (MujocoPlant.check's test).")
      .def("state", &PlantStep::state, "(q, v) in pinocchio conventions, new arrays.")
      .def("set_torques", &PlantStep::set_torques, "tau"_a,
           "Joint torques (N m, pinocchio order) into ctrl; ValueError unless na finite ones.")
      .def("step", &PlantStep::step, "mj_step, then check(): the new sim time, -1 if not valid.")
      .def("foot_normal_forces", &PlantStep::foot_normal_forces,
           "Per foot, its largest normal force on the terrain at the last step (N).")
      .def("foot_forces", &PlantStep::foot_forces, "out"_a.noconvert(),
           "Per foot, the terrain's force on it at the last step (N, world), into out (n x 3).")
      .def("non_foot_ground_contact", &PlantStep::non_foot_ground_contact,
           "Whether a robot geom other than the feet touches the terrain.");
}
