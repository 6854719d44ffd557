// lab._plant: the per-tick exchange of lab/server/plant.py (MujocoPlant) with MuJoCo in one
// crossing each: the state check, the state in pinocchio conventions, the torques, the step,
// and the feet's contacts with the terrain. It works on the MjModel and MjData the Python plant
// built (their `_address`), through the MuJoCo C API of the same wheel (its headers and
// libmujoco), and mirrors plant.py's functions of the same names; plant.py keeps its Python
// path for when this module is not built, and tests/test_plant_native.py holds the two equal.
#include <mujoco/mujoco.h>
#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/tuple.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace nb = nanobind;
using namespace nb::literals;

namespace {

using Indices = nb::ndarray<const long long, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Doubles = nb::ndarray<const double, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
using Array = nb::ndarray<nb::numpy, double, nb::ndim<1>>;

constexpr int kBadStateWarnings[] = {mjWARN_BADQPOS, mjWARN_BADQVEL, mjWARN_BADQACC};
constexpr mjtNum kMaxStateSquared = mjMAXVAL * mjMAXVAL;

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

class PlantStep {
 public:
  PlantStep(nb::object mj_model, nb::object mj_data, const Indices& q_order, const Indices& v_order,
            const Indices& terrain, const Indices& foot_of_geom, int n_feet)
      : model_object_(std::move(mj_model)),
        data_object_(std::move(mj_data)),
        m_(address_of<const mjModel>(model_object_)),
        d_(address_of<mjData>(data_object_)),
        q_order_(as_ints(q_order)),
        v_order_(as_ints(v_order)),
        terrain_(as_ints(terrain)),
        foot_of_geom_(as_ints(foot_of_geom)),
        n_feet_(n_feet) {
    if (static_cast<int>(terrain_.size()) != m_->ngeom ||
        static_cast<int>(foot_of_geom_.size()) != m_->ngeom)
      throw std::invalid_argument("PlantStep: terrain and foot_of_geom need one entry per geom");
    for (int i : q_order_)
      if (i < 0 || i >= m_->nq) throw std::invalid_argument("PlantStep: q_order out of range");
    for (int i : v_order_)
      if (i < 0 || i >= m_->nv) throw std::invalid_argument("PlantStep: v_order out of range");
    if (q_order_.size() < 7 || v_order_.size() < 6)
      throw std::invalid_argument("PlantStep: the robot needs a free base (7 q, 6 v)");
  }

  /// plant.py `check`'s test: the sim time when the state is valid, else -1 (MuJoCo flagged a
  /// bad position, velocity or acceleration since the last reset, or qpos or qvel is not
  /// finite or beyond mjMAXVAL); the Python side then names the cause. The time comes along
  /// because reading MjData.time from Python costs more than this whole call.
  double check() const {
    for (int kind : kBadStateWarnings)
      if (d_->warning[kind].number) return -1.0;
    mjtNum sum = mju_dot(d_->qpos, d_->qpos, m_->nq) + mju_dot(d_->qvel, d_->qvel, m_->nv);
    return sum < kMaxStateSquared ? d_->time : -1.0;  // NaN fails the comparison
  }

  /// plant.py `state`: (q, v) in pinocchio conventions, new arrays.
  nb::tuple state() const {
    double *q, *v;
    Array q_array = new_array(q_order_.size(), q), v_array = new_array(v_order_.size(), v);
    for (std::size_t i = 0; i < q_order_.size(); ++i) q[i] = d_->qpos[q_order_[i]];
    for (std::size_t i = 0; i < v_order_.size(); ++i) v[i] = d_->qvel[v_order_[i]];
    mjtNum rotation[9], world[3] = {v[0], v[1], v[2]};
    mju_quat2Mat(rotation, d_->qpos + 3);
    mju_mulMatTVec3(v, rotation, world);  // linear velocity: world -> base frame
    return nb::make_tuple(q_array, v_array);
  }

  /// plant.py `set_torques`: joint torques in pinocchio joint order into ctrl.
  void set_torques(const Doubles& tau) {
    if (static_cast<int>(tau.size()) != m_->nu)
      throw std::invalid_argument("set_torques needs " + std::to_string(m_->nu) +
                                  " finite torques (N m)");
    for (int i = 0; i < m_->nu; ++i)
      if (!std::isfinite(tau(i)))
        throw std::invalid_argument("set_torques needs " + std::to_string(m_->nu) +
                                    " finite torques (N m)");
    mju_copy(d_->ctrl, tau.data(), m_->nu);
  }

  /// mj_step, then `check`'s test (the new sim time, -1: not valid). The GIL stays held, as in
  /// the kernel's solve.
  double step() {
    mj_step(m_, d_);
    return check();
  }

  /// Per foot, the largest normal force (N) of its contacts with the terrain at the last step
  /// (0 without one): plant.py `feet_touching(f)` is this > f.
  Array foot_normal_forces() const {
    double* out;
    Array array = new_array(static_cast<std::size_t>(n_feet_), out);
    std::fill(out, out + n_feet_, 0.0);
    for (int i = 0; i < d_->ncon; ++i) {
      const int foot = robot_geom_of(d_->contact[i]);
      const int row = d_->contact[i].efc_address;
      if (foot >= 0 && row >= 0 && d_->efc_force[row] > out[foot]) out[foot] = d_->efc_force[row];
    }
    return array;
  }

  /// plant.py `foot_forces`: per foot (rows), the terrain's force on it (N, world) at the last
  /// step, summed over its contacts: each contact's force (mj_contactForce, contact frame)
  /// rotated into the world, acting from geom1 onto geom2.
  void foot_forces(nb::ndarray<double, nb::shape<-1, 3>, nb::c_contig, nb::device::cpu> out) const {
    if (out.shape(0) != static_cast<std::size_t>(n_feet_))
      throw std::invalid_argument("foot_forces needs an array of " + std::to_string(n_feet_) +
                                  " x 3");
    double* forces = out.data();
    std::fill(forces, forces + 3 * n_feet_, 0.0);
    mjtNum local[6], world[3];
    for (int i = 0; i < d_->ncon; ++i) {
      const mjContact& contact = d_->contact[i];
      const int foot = robot_geom_of(contact);
      if (foot < 0 || contact.efc_address < 0) continue;
      mj_contactForce(m_, d_, i, local);
      mju_mulMatTVec3(world, contact.frame, local);  // the frame's rows are the contact's axes
      const double sign = terrain_[contact.geom[0]] ? 1.0 : -1.0;  // robot geom is geom2: +1
      for (int k = 0; k < 3; ++k) forces[3 * foot + k] += sign * world[k];
    }
  }

  /// plant.py `non_foot_ground_contact`: does a robot geom other than the feet touch the
  /// terrain?
  bool non_foot_ground_contact() const {
    for (int i = 0; i < d_->ncon; ++i)
      if (robot_geom_of(d_->contact[i]) == kNotAFoot) return true;
    return false;
  }

 private:
  static constexpr int kNoTerrainContact = -2;
  static constexpr int kNotAFoot = -1;

  /// The foot of a contact between the robot and the terrain (kNotAFoot for another robot
  /// geom), or kNoTerrainContact (both geoms terrain, or both robot).
  int robot_geom_of(const mjContact& contact) const {
    const int g1 = contact.geom[0], g2 = contact.geom[1];
    if (g1 < 0 || g2 < 0 || terrain_[g1] == terrain_[g2]) return kNoTerrainContact;
    const int foot = foot_of_geom_[terrain_[g1] ? g2 : g1];
    return foot >= 0 ? foot : kNotAFoot;
  }

  nb::object model_object_, data_object_;  // keep the structs alive
  const mjModel* m_;
  mjData* d_;
  std::vector<int> q_order_, v_order_, terrain_, foot_of_geom_;
  int n_feet_;
};

}  // namespace

NB_MODULE(_plant, m) {
  m.doc() = "The plant's per-tick exchange with MuJoCo in C (lab/server/plant.py; cpp/README.md).";
  m.attr("mujoco_version") = mj_versionString();
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
