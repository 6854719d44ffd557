// lab::MujocoStep: the plant's per-tick exchange with MuJoCo (lab/world/plant.py's check, state,
// set_torques, step and the feet's contacts), on raw MjModel / MjData pointers. Header-only: both
// lab._plant (plant.cpp, PlantStep's calls one by one) and lab._kernel (server_tick.cpp, the whole
// server tick in one call) compile it, each against the same wheel's libmujoco.
#pragma once

#include <mujoco/mujoco.h>

#include <algorithm>
#include <stdexcept>
#include <vector>

namespace lab {

class MujocoStep {
 public:
  /// On the plant's structs: qpos and qvel indices of pinocchio's q and v, per geom whether it is
  /// terrain and which foot it is (or -1), the foot count. Throws std::invalid_argument.
  MujocoStep(const mjModel* m, mjData* d, std::vector<int> q_order, std::vector<int> v_order,
             std::vector<int> terrain, std::vector<int> foot_of_geom, int n_feet)
      : m_(m),
        d_(d),
        q_order_(std::move(q_order)),
        v_order_(std::move(v_order)),
        terrain_(std::move(terrain)),
        foot_of_geom_(std::move(foot_of_geom)),
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

  int nq() const { return static_cast<int>(q_order_.size()); }
  int nv() const { return static_cast<int>(v_order_.size()); }
  int nu() const { return m_->nu; }
  int n_feet() const { return n_feet_; }
  double time() const { return d_->time; }
  const double* ctrl() const { return d_->ctrl; }

  /// plant.py `check`'s test: the sim time when the state is valid, else -1 (MuJoCo flagged a
  /// bad position, velocity or acceleration since the last reset, or qpos or qvel is not
  /// finite or beyond mjMAXVAL); the Python side then names the cause.
  double check() const {
    for (int kind : {mjWARN_BADQPOS, mjWARN_BADQVEL, mjWARN_BADQACC})
      if (d_->warning[kind].number) return -1.0;
    const mjtNum sum = mju_dot(d_->qpos, d_->qpos, m_->nq) + mju_dot(d_->qvel, d_->qvel, m_->nv);
    return sum < mjMAXVAL * mjMAXVAL ? d_->time : -1.0;  // NaN fails the comparison
  }

  /// plant.py `state`: (q, v) in pinocchio conventions into q (nq) and v (nv).
  void state(double* q, double* v) const {
    for (std::size_t i = 0; i < q_order_.size(); ++i) q[i] = d_->qpos[q_order_[i]];
    for (std::size_t i = 0; i < v_order_.size(); ++i) v[i] = d_->qvel[v_order_[i]];
    mjtNum rotation[9], world[3] = {v[0], v[1], v[2]};
    mju_quat2Mat(rotation, d_->qpos + 3);
    mju_mulMatTVec3(v, rotation, world);  // linear velocity: world -> base frame
  }

  /// Joint torques (nu, pinocchio joint order) into ctrl; the caller checked they are finite.
  void set_torques(const double* tau) { mju_copy(d_->ctrl, tau, m_->nu); }

  /// mj_step, then `check`'s test (the new sim time, -1: not valid).
  double step() {
    mj_step(m_, d_);
    return check();
  }

  /// Per foot, the largest normal force (N) of its contacts with the terrain at the last step
  /// (0 without one), into out (n_feet): plant.py `feet_touching(f)` is this > f.
  void foot_normal_forces(double* out) const {
    std::fill(out, out + n_feet_, 0.0);
    for (int i = 0; i < d_->ncon; ++i) {
      const int foot = robot_geom_of(d_->contact[i]);
      const int row = d_->contact[i].efc_address;
      if (foot >= 0 && row >= 0 && d_->efc_force[row] > out[foot]) out[foot] = d_->efc_force[row];
    }
  }

  /// plant.py `foot_forces`: per foot (rows of 3), the terrain's force on it (N, world) at the
  /// last step, summed over its contacts: each contact's force (mj_contactForce, contact frame)
  /// rotated into the world, acting from geom1 onto geom2.
  void foot_forces(double* forces) const {
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

  const mjModel* m_;
  mjData* d_;
  std::vector<int> q_order_, v_order_, terrain_, foot_of_geom_;
  int n_feet_;
};

}  // namespace lab
