// lab/estimation/filter.py in C++: the EKF (predict with the IMU, make a foot's state at its
// touchdown, correct with the leg kinematics of the feet in contact; see there for the model,
// the touchdown-uncertainty rule and why). tests/estimation/test_ekf_native.py holds the two
// equal over a recorded trot.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <limits>

#include "estimation/measurement.hpp"
#include "estimation/state.hpp"

namespace lab::estimation {

using Flags = Eigen::Array<bool, Eigen::Dynamic, 1>;

/// The base's pose, twist and IMU biases of a robot whose feet `kinematics` gives (spheres of
/// `radii` m about those points, 0 for a point or a sole), ticked every `dt` s under `gravity`.
class LeggedEkf {
 public:
  LeggedEkf(LegKinematics kinematics, const Eigen::VectorXd& radii, const Eigen::Vector3d& gravity,
            double dt, const EkfTuning& tuning = EkfTuning());
  /// Start at the known state (q, v), no bias, no foot in contact yet.
  void reset(const Eigen::Ref<const Eigen::VectorXd>& q,
             const Eigen::Ref<const Eigen::VectorXd>& v);
  /// One tick: IMU `accel` (m/s²), `gyro` (rad/s, base frame), joint angles and rates at its
  /// end, the feet in `contacts`.
  void step(const Eigen::Vector3d& accel, const Eigen::Vector3d& gyro,
            const Eigen::Ref<const Eigen::VectorXd>& joints,
            const Eigen::Ref<const Eigen::VectorXd>& joint_velocities, const Flags& contacts);
  /// q = [p̂, R̂ as a quaternion (x, y, z, w), joints] into `q` (its joints already there).
  void configuration(Eigen::Ref<Eigen::VectorXd> q) const;
  /// v = [R̂ᵀ v̂, ω̃ − b̂_g, joint rates] into `v` (its joint rates already there).
  void velocity(const Eigen::Vector3d& gyro, Eigen::Ref<Eigen::VectorXd> v) const;

  const NominalState& x() const { return x_; }
  const Eigen::MatrixXd& P() const { return P_; }
  const Flags& contacts() const { return contacts_; }
  double since_touchdown() const { return since_touchdown_; }

 private:
  void touchdown(int i, const Eigen::Vector3d& measured);
  void correct(const Eigen::Matrix3Xd& feet);
  /// out = X Hᵀ from H's nonzero blocks (p, θ and each standing foot's).
  void times_ht(const Eigen::MatrixXd& X, const Eigen::MatrixXd& H, Eigen::MatrixXd& out) const;
  void inject(const Eigen::VectorXd& dx);

  LegKinematics kinematics_;
  Eigen::VectorXd radii_;
  Eigen::Vector3d gravity_;
  double dt_;
  EkfTuning tuning_;
  ErrorLayout layout_;
  bool rolling_;
  NominalState x_;
  Eigen::MatrixXd P_, work_, H_, PHt_, S_, U_;  // preallocated after the first ticks
  Eigen::LLT<Eigen::MatrixXd> llt_;
  Eigen::VectorXd q_, residual_, dx_;
  Flags contacts_;
  double since_touchdown_ = std::numeric_limits<double>::infinity();
};

/// The covariance (3 × 3, base frame) of one foot's kinematics reading `since_touchdown` s
/// after the last touchdown, the base's orientation `rotation` (filter.py).
Eigen::Matrix3d kinematics_noise(const EkfTuning& tuning, const Eigen::Matrix3d& rotation,
                                 double since_touchdown);

}  // namespace lab::estimation
