// lab/estimation/filter.py in C++ (same steps, same order; Eigen for the algebra, pinocchio's
// exp3 for the rotation).
#include "estimation/filter.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/spatial/explog.hpp>
#include <stdexcept>

#include "estimation/process.hpp"

namespace lab::estimation {

LeggedEkf::LeggedEkf(LegKinematics kinematics, const Eigen::VectorXd& radii,
                     const Eigen::Vector3d& gravity, double dt, const EkfTuning& tuning)
    : kinematics_(std::move(kinematics)),
      radii_(radii),
      gravity_(gravity),
      dt_(dt),
      tuning_(tuning),
      layout_(kinematics_.size()),
      rolling_((radii.array() > 0.0).any()) {
  if (radii.size() != layout_.n) throw std::invalid_argument("LeggedEkf: one radius per foot");
  const pinocchio::Model& model = kinematics_.model();
  reset(pinocchio::neutral(model), Eigen::VectorXd::Zero(model.nv));
}

void LeggedEkf::reset(const Eigen::Ref<const Eigen::VectorXd>& q,
                      const Eigen::Ref<const Eigen::VectorXd>& v) {
  const Eigen::Matrix3d rotation =
      Eigen::Quaterniond(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix();
  x_.position = q.head<3>();
  x_.velocity = rotation * v.head<3>();
  x_.rotation = rotation;
  x_.feet = (rotation * kinematics_.feet(q.tail(q.size() - 7))).colwise() + x_.position;
  x_.accel_bias.setZero();
  x_.gyro_bias.setZero();
  Eigen::VectorXd sigma = Eigen::VectorXd::Zero(layout_.size);
  sigma.segment<3>(layout_.p).setConstant(tuning_.initial_position);
  sigma.segment<3>(layout_.v).setConstant(tuning_.initial_velocity);
  sigma.segment<3>(layout_.theta).setConstant(tuning_.initial_orientation);
  sigma.segment<3>(layout_.accel_bias()).setConstant(tuning_.initial_accel_bias);
  sigma.segment<3>(layout_.gyro_bias()).setConstant(tuning_.initial_gyro_bias);
  for (int i = 0; i < layout_.n; ++i)
    sigma.segment<3>(layout_.foot(i)).setConstant(tuning_.kinematics);
  P_ = sigma.array().square().matrix().asDiagonal();
  contacts_ = Flags::Constant(layout_.n, false);
  since_touchdown_ = std::numeric_limits<double>::infinity();
}

void LeggedEkf::step(const Eigen::Vector3d& accel, const Eigen::Vector3d& gyro,
                     const Eigen::Ref<const Eigen::VectorXd>& joints,
                     const Eigen::Ref<const Eigen::VectorXd>& joint_velocities,
                     const Flags& contacts) {
  if (contacts.size() != layout_.n)
    throw std::invalid_argument("LeggedEkf.step: one contact flag per foot");
  // one forward pass for both: the spins (rolling feet) and the feet's kinematics
  const Eigen::Matrix3Xd& feet =
      rolling_ ? kinematics_.feet_and_spins(joints, joint_velocities) : kinematics_.feet(joints);
  if (rolling_) roll_feet(x_, kinematics_.last_spins(), gyro, radii_, contacts_, dt_);
  const Transition F = transition(x_, accel, gyro, dt_);
  propagate(x_, accel, gyro, gravity_, dt_);
  propagate_covariance(F, layout_, P_, work_);
  process_noise(tuning_, contacts_, dt_, layout_, q_);
  P_.diagonal() += q_;
  for (int i = 0; i < layout_.n; ++i) {
    if (contacts[i] && !contacts_[i]) {
      touchdown(i, feet.col(i));
      since_touchdown_ = 0.0;
    }
  }
  contacts_ = contacts;
  correct(feet);
  since_touchdown_ += dt_;
}

void LeggedEkf::touchdown(int i, const Eigen::Vector3d& measured) {
  // P ← T P Tᵀ, T the identity but for foot i's rows (touchdown_map): only those rows and
  // columns change
  const int foot = layout_.foot(i);
  const Eigen::MatrixXd A = touchdown_map(x_, measured, layout_);
  const Eigen::MatrixXd AP = A * P_;  // T P's rows of foot i
  const Eigen::Matrix3d block = AP * A.transpose();
  P_.middleRows<3>(foot) = AP;
  P_.middleCols<3>(foot) = AP.transpose();
  P_.block<3, 3>(foot, foot) = block;
  P_.block<3, 3>(foot, foot).diagonal().array() += tuning_.kinematics * tuning_.kinematics;
  x_.feet.col(i) = x_.position + x_.rotation * measured;
}

void LeggedEkf::times_ht(const Eigen::MatrixXd& X, const Eigen::MatrixXd& H,
                         Eigen::MatrixXd& out) const {
  out.resize(X.rows(), H.rows());
  int row = 0;
  for (int i = 0; i < layout_.n; ++i) {
    if (!contacts_[i]) continue;
    const int foot = layout_.foot(i);
    auto block = out.middleCols<3>(row);
    block.noalias() = X.middleCols<3>(layout_.p) * H.block<3, 3>(row, layout_.p).transpose();
    block.noalias() +=
        X.middleCols<3>(layout_.theta) * H.block<3, 3>(row, layout_.theta).transpose();
    block.noalias() += X.middleCols<3>(foot) * H.block<3, 3>(row, foot).transpose();
    row += 3;
  }
}

void LeggedEkf::correct(const Eigen::Matrix3Xd& feet) {
  const int m = static_cast<int>(contacts_.count());
  if (m == 0) return;
  H_.setZero(3 * m, layout_.size);
  residual_.resize(3 * m);
  int row = 0;
  for (int i = 0; i < layout_.n; ++i) {
    if (!contacts_[i]) continue;
    foot_innovation(x_, i, feet.col(i), layout_, residual_.segment<3>(row), H_.middleRows(row, 3));
    row += 3;
  }
  const Eigen::Matrix3d noise = kinematics_noise(tuning_, x_.rotation, since_touchdown_);
  // H's only nonzero blocks are p, θ and the foot's: products with Hᵀ go block by block
  times_ht(P_, H_, PHt_);
  times_ht(PHt_.transpose(), H_, S_);                                 // H P Hᵀ (P symmetric)
  for (int k = 0; k < m; ++k) S_.block<3, 3>(3 * k, 3 * k) += noise;  // + N, feet independent
  // filter.py's Joseph form (I − KH) P (I − KH)ᵀ + K N Kᵀ with the optimal K = P Hᵀ S⁻¹ is, in
  // exact arithmetic, P − K S Kᵀ = P − U Uᵀ, U = P Hᵀ L⁻ᵀ (S = L Lᵀ): one symmetric rank-3m
  // update instead of two dense 27 × 12 × 27 products;
  // tests/estimation/test_ekf_native.py holds it to the Joseph form's P every tick
  llt_.compute(S_);
  U_ = PHt_;
  llt_.matrixU().solveInPlace<Eigen::OnTheRight>(U_);
  P_.selfadjointView<Eigen::Lower>().rankUpdate(U_, -1.0);
  P_.triangularView<Eigen::StrictlyUpper>() = P_.transpose();
  llt_.matrixL().solveInPlace(residual_);  // K r = U L⁻¹ r
  dx_.noalias() = U_ * residual_;
  inject(dx_);
}

void LeggedEkf::inject(const Eigen::VectorXd& dx) {
  x_.position += dx.segment<3>(layout_.p);
  x_.velocity += dx.segment<3>(layout_.v);
  x_.rotation = x_.rotation * pinocchio::exp3(Eigen::Vector3d(dx.segment<3>(layout_.theta)));
  for (int i = 0; i < layout_.n; ++i) x_.feet.col(i) += dx.segment<3>(layout_.foot(i));
  x_.accel_bias += dx.segment<3>(layout_.accel_bias());
  x_.gyro_bias += dx.segment<3>(layout_.gyro_bias());
}

void LeggedEkf::configuration(Eigen::Ref<Eigen::VectorXd> q) const {
  q.head<3>() = x_.position;
  q.segment<4>(3) = Eigen::Quaterniond(x_.rotation).normalized().coeffs();
}

void LeggedEkf::velocity(const Eigen::Vector3d& gyro, Eigen::Ref<Eigen::VectorXd> v) const {
  v.head<3>() = x_.rotation.transpose() * x_.velocity;
  v.segment<3>(3) = gyro - x_.gyro_bias;
}

Eigen::Matrix3d kinematics_noise(const EkfTuning& tuning, const Eigen::Matrix3d& rotation,
                                 double since_touchdown) {
  Eigen::Matrix3d noise = tuning.kinematics * tuning.kinematics * Eigen::Matrix3d::Identity();
  if (since_touchdown < tuning.settle) {
    const Eigen::Vector3d up = rotation.row(2).transpose();  // the world's vertical: Rᵀ e_z
    noise += (tuning.settling_kinematics * tuning.settling_kinematics -
              tuning.kinematics * tuning.kinematics) *
             up * up.transpose();
  }
  return noise;
}

}  // namespace lab::estimation
