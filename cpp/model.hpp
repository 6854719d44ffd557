// RobotModel: the one place that talks to pinocchio (mirrors lab/controller/model.py).
//
// One update(q, v) per tick runs computeAllTerms and exposes what the tasks and constraints need,
// in pinocchio's conventions: q = [base position, quaternion (x, y, z, w), joints], v with the
// base velocity in the base frame, x = [qdd, F] with one force block per contact (a point foot's
// force in world axes, a flat foot's wrench in its sole frame).
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <pinocchio/multibody/fwd.hpp>  // only the declarations: task files compile Eigen alone
#include <string>
#include <vector>

namespace lab {

constexpr int BASE_DOF = 6;

enum class ContactKind { point, flat };

/// One foot (lab/protocol.py ContactSpec).
struct ContactSpec {
  std::string name;
  std::string frame;
  ContactKind kind = ContactKind::point;
  double radius = 0.0;
  double half_length = 0.0;
  double half_width = 0.0;

  int force_dim() const { return kind == ContactKind::point ? 3 : 6; }
};

/// The model pinocchio serialized on the Python side (`Model.saveToString()`); throws
/// std::invalid_argument for another string.
std::unique_ptr<pinocchio::Model> load_model(const std::string& serialized_model);

/// Kinematics and dynamics of one floating-base robot at the current state.
class RobotModel {
 public:
  /// From the model pinocchio serialized on the Python side (`Model.saveToString()`): the same
  /// model, never a second one built here. Throws std::invalid_argument for another string.
  RobotModel(const std::string& serialized_model, std::vector<ContactSpec> contacts);
  ~RobotModel();
  RobotModel(const RobotModel&) = delete;
  RobotModel& operator=(const RobotModel&) = delete;

  /// Recompute everything at state (q, v) in one pinocchio pass; no allocation.
  void update(const Eigen::Ref<const Eigen::VectorXd>& q,
              const Eigen::Ref<const Eigen::VectorXd>& v);

  /// tau = M_a qdd + h_a - J_a^T F, the actuated rows of the dynamics (Herzog eq. 14).
  void joint_torques(const Eigen::Ref<const Eigen::VectorXd>& x,
                     Eigen::Ref<Eigen::VectorXd> tau) const;

  /// Flags of the force rows of the contacts flagged in `flags` (np.repeat(flags, force_dims)),
  /// into `rows`.
  void force_rows_of(const Eigen::Array<bool, Eigen::Dynamic, 1>& flags,
                     Eigen::Array<bool, Eigen::Dynamic, 1>& rows) const;

  /// Ȧ_G v, the rate of change of the centroidal momentum at q̈ = 0 (Herzog eq. 20), world axes,
  /// [linear; angular] about the CoM, at the last update.
  const Eigen::Matrix<double, 6, 1>& centroidal_drift() const { return centroidal_drift_; }

  /// Names of the model's frames, in pinocchio order.
  std::vector<std::string> frame_names() const;
  /// Each joint's body inertia as pinocchio's 10 dynamic parameters (one row per joint).
  Eigen::MatrixXd inertia_parameters() const;

  std::unique_ptr<pinocchio::Model> model;
  std::unique_ptr<pinocchio::Data> data;
  std::vector<ContactSpec> contacts;
  std::vector<pinocchio::FrameIndex> frame_ids;
  std::vector<int> force_starts;  // first row of each contact's block in F
  int nq, nv, na, nf, nx;
  double mass;

  // Filled by update(), preallocated.
  Eigen::VectorXd q, v;
  Eigen::MatrixXd M;  // symmetric
  Eigen::VectorXd h;
  Eigen::MatrixXd Jc;
  Eigen::VectorXd Jc_dot_v;
  Eigen::Vector3d com, com_velocity, com_drift;
  Eigen::MatrixXd Jcom;
  Eigen::Matrix<double, 6, Eigen::Dynamic> centroidal_map;  // A_G: h_G = A_G v (Herzog eq. 19)
  Eigen::Matrix3d base_rotation;
  std::vector<Eigen::Vector3d> contact_positions;
  std::vector<Eigen::Matrix3d> contact_rotations;

 private:
  Eigen::Matrix<double, 6, Eigen::Dynamic> frame_jacobian_;  // scratch
  Eigen::Matrix<double, 6, 1> centroidal_drift_ = Eigen::Matrix<double, 6, 1>::Zero();
};

}  // namespace lab
