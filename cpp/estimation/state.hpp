// lab/estimation/state.py and tuning.py in C++: the filter's nominal state, the layout of its
// error and the filter's tuning (see there for the state, the units and why these values).
#pragma once

#include <Eigen/Core>

namespace lab::estimation {

/// Where each part of δx sits, for `n` feet: p, v, θ, d_1 … d_n, b_a, b_g (3 entries each).
struct ErrorLayout {
  explicit ErrorLayout(int feet) : n(feet), size(15 + 3 * feet) {}
  static constexpr int p = 0, v = 3, theta = 6;
  int foot(int i) const { return 9 + 3 * i; }
  int accel_bias() const { return 9 + 3 * n; }
  int gyro_bias() const { return 12 + 3 * n; }
  int n, size;
};

/// x̂ (SI units, world axes but for the biases); feet one column each (3 × n).
struct NominalState {
  Eigen::Vector3d position, velocity;
  Eigen::Matrix3d rotation;
  Eigen::Matrix3Xd feet;
  Eigen::Vector3d accel_bias, gyro_bias;
};

/// tuning.py's EkfTuning: what the EKF assumes of its sensors and of the feet.
struct EkfTuning {
  double accel_noise = 0.05;  // m/s²/√Hz
  double gyro_noise = 1e-3;   // rad/s/√Hz
  double accel_bias_walk = 1e-3;
  double gyro_bias_walk = 1e-4;
  double foot_slip = 0.01;            // m/√s
  double kinematics = 0.005;          // m
  double settle = 0.2;                // s
  double settling_kinematics = 0.05;  // m
  double initial_position = 1e-3;
  double initial_velocity = 1e-3;
  double initial_orientation = 1e-3;
  double initial_accel_bias = 0.01;
  double initial_gyro_bias = 0.02;
};

}  // namespace lab::estimation
