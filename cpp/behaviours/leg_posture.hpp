// Posture references of the legs from their feet (Raiola §3.4, eqs. 30-32); mirrors
// lab/controller/behaviours/leg_posture.py (LegPostureReference.update), whose docstring
// derives each term. The Python class keeps the state and calls this on a native tick.
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace lab {

using RowMatrixX3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using RowMatrixX = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// What one tick of the legs' posture references reads (world axes; n point feet).
struct LegPostureInput {
  Eigen::Map<const RowMatrixX3> contact_positions;  // n x 3, the feet now
  Eigen::Map<const RowMatrixX3> contact_rotations;  // 3n x 3, the feet's orientations now
  Eigen::Map<const RowMatrixX> contact_jacobian;    // 3n x nv, the feet's Jacobian (J_c)
  Eigen::Map<const Eigen::VectorXd> radius;         // n, the foot spheres' radii
  const bool* stance;                               // n, legs in stance
  Eigen::Map<const RowMatrixX3> foot_position;      // n x 3, swing references
  Eigen::Map<const RowMatrixX3> foot_velocity;      // n x 3
  Eigen::Vector3d base_position, base_velocity, base_angular_velocity;
  double height_error;  // ΔH_z of eq. 32
  double dt;
  double damping;  // λ of the damped least squares
};

/// q̇_d of every leg (eqs. 30-31) into `velocity` (na), and the feet's orientations into
/// `previous_rotations` (3n x 3, last tick's on entry: the rolling of a stance foot).
void leg_posture_velocity(const LegPostureInput& in, Eigen::Map<RowMatrixX3> previous_rotations,
                          Eigen::Map<Eigen::VectorXd> velocity);

/// LegPostureReference.restart: q_d of `leg` (its joints `joints[leg]`, indices into the na
/// actuated joints) from the measured joint positions, plus the mean horizontal lag of the base
/// behind the references of the legs `carry_from` (point feet: 3 rows of J_c each).
void leg_posture_restart(const Eigen::Ref<const RowMatrixX>& contact_jacobian,
                         const Eigen::Ref<const Eigen::VectorXd>& joint_positions,
                         const std::vector<std::vector<int>>& joints, int leg,
                         const std::vector<int>& carry_from, double damping,
                         Eigen::Ref<Eigen::VectorXd> position);

}  // namespace lab
