// lab/estimation/measurement.py in C++: the leg kinematics of the feet in contact and a foot's
// entry into the state at its touchdown (see there for the equations).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <pinocchio/multibody/fwd.hpp>
#include <string>
#include <vector>

#include "estimation/state.hpp"

namespace lab::estimation {

/// Each contact frame's position in the base frame from the joint angles (pinocchio's forward
/// kinematics on the robot's free-flyer model, the base at the origin).
class LegKinematics {
 public:
  LegKinematics(const pinocchio::Model& model, const std::vector<std::string>& frames);
  ~LegKinematics();
  LegKinematics(LegKinematics&&) noexcept;
  /// (3 × n): each foot's position (m, base frame) at joint angles `joints` (rad).
  const Eigen::Matrix3Xd& feet(const Eigen::Ref<const Eigen::VectorXd>& joints);
  /// (3 × n): each foot's angular velocity relative to the base (rad/s, base frame).
  const Eigen::Matrix3Xd& spins(const Eigen::Ref<const Eigen::VectorXd>& joints,
                                const Eigen::Ref<const Eigen::VectorXd>& joint_velocities);
  /// Both of the above in one forward pass; the spins then in `last_spins`.
  const Eigen::Matrix3Xd& feet_and_spins(const Eigen::Ref<const Eigen::VectorXd>& joints,
                                         const Eigen::Ref<const Eigen::VectorXd>& joint_velocities);
  const Eigen::Matrix3Xd& last_spins() const { return spins_; }
  const pinocchio::Model& model() const { return *model_; }
  int size() const { return static_cast<int>(frame_ids_.size()); }

 private:
  std::unique_ptr<pinocchio::Model> model_;
  std::unique_ptr<pinocchio::Data> data_;
  std::vector<std::size_t> frame_ids_;
  Eigen::VectorXd q_, v_;
  Eigen::Matrix3Xd feet_, spins_;
};

/// Foot `i`'s residual s̃_i − s_i(x̂) into `residual`, its rows of H into `H` (3 × layout.size,
/// zero outside the blocks this writes: the caller zeroes it).
void foot_innovation(const NominalState& x, int i, const Eigen::Vector3d& measured,
                     const ErrorLayout& layout, Eigen::Ref<Eigen::Vector3d> residual,
                     Eigen::Ref<Eigen::MatrixXd> H);

/// The rows (3 × layout.size) giving a touching-down foot's δd_i from the rest of δx, its
/// kinematics reading `measured` (base frame): [I at δp, −R̂ [s̃]× at δθ].
Eigen::MatrixXd touchdown_map(const NominalState& x, const Eigen::Vector3d& measured,
                              const ErrorLayout& layout);

}  // namespace lab::estimation
