// lab/estimation/process.py in C++: the IMU's propagation of the nominal state, the error's
// transition and noise (see there for the equations).
#pragma once

#include <Eigen/Core>

#include "estimation/state.hpp"

namespace lab::estimation {

/// Advance `x` in place by one tick of IMU readings `accel` (m/s²) and `gyro` (rad/s).
void propagate(NominalState& x, const Eigen::Vector3d& accel, const Eigen::Vector3d& gyro,
               const Eigen::Vector3d& gravity, double dt);

/// Move the centres of the rolling feet in `stance` in place; `spins` (3 × n) each foot's
/// angular velocity relative to the base (base frame), `radii` their radii (m).
void roll_feet(NominalState& x, const Eigen::Matrix3Xd& spins, const Eigen::Vector3d& gyro,
               const Eigen::VectorXd& radii, const Eigen::Array<bool, Eigen::Dynamic, 1>& stance,
               double dt);

/// F of process.py: the identity but for these blocks (rows p, v, θ), so that F P Fᵀ costs
/// a few 3-row and 3-column products instead of two dense ones.
struct Transition {
  double dt;                      // F[p, v] = dt I
  Eigen::Matrix3d v_theta, v_ba;  // F[v, θ] = −dt R [â]×, F[v, b_a] = −dt R
  Eigen::Matrix3d theta_theta;    // F[θ, θ] = Exp(ω̂ dt)ᵀ; F[θ, b_g] = −dt I
};

/// F at `x` before it is propagated.
Transition transition(const NominalState& x, const Eigen::Vector3d& accel,
                      const Eigen::Vector3d& gyro, double dt);

/// P ← F P Fᵀ in place (`work` a scratch matrix of P's size).
void propagate_covariance(const Transition& F, const ErrorLayout& layout, Eigen::MatrixXd& P,
                          Eigen::MatrixXd& work);

/// The diagonal of Q for one tick, into `q` (layout.size).
void process_noise(const EkfTuning& tuning, const Eigen::Array<bool, Eigen::Dynamic, 1>& stance,
                   double dt, const ErrorLayout& layout, Eigen::VectorXd& q);

}  // namespace lab::estimation
