// lab/estimation/measurement.py in C++ (pinocchio's forward kinematics and skew).
#include "estimation/measurement.hpp"

#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/spatial/skew.hpp>
#include <stdexcept>

namespace lab::estimation {

LegKinematics::LegKinematics(const pinocchio::Model& model, const std::vector<std::string>& frames)
    : model_(std::make_unique<pinocchio::Model>(model)),
      data_(std::make_unique<pinocchio::Data>(model)),
      q_(pinocchio::neutral(model)),
      v_(Eigen::VectorXd::Zero(model.nv)),
      feet_(3, frames.size()),
      spins_(3, frames.size()) {
  for (const std::string& frame : frames) {
    if (!model.existFrame(frame))
      throw std::invalid_argument("LegKinematics: the model has no frame " + frame);
    frame_ids_.push_back(model.getFrameId(frame));
  }
}

LegKinematics::~LegKinematics() = default;
LegKinematics::LegKinematics(LegKinematics&&) noexcept = default;

const Eigen::Matrix3Xd& LegKinematics::feet(const Eigen::Ref<const Eigen::VectorXd>& joints) {
  q_.tail(joints.size()) = joints;
  pinocchio::framesForwardKinematics(*model_, *data_, q_);
  for (std::size_t i = 0; i < frame_ids_.size(); ++i)
    feet_.col(static_cast<Eigen::Index>(i)) = data_->oMf[frame_ids_[i]].translation();
  return feet_;
}

const Eigen::Matrix3Xd& LegKinematics::spins(
    const Eigen::Ref<const Eigen::VectorXd>& joints,
    const Eigen::Ref<const Eigen::VectorXd>& joint_velocities) {
  q_.tail(joints.size()) = joints;
  v_.tail(joint_velocities.size()) = joint_velocities;
  pinocchio::forwardKinematics(*model_, *data_, q_, v_);
  for (std::size_t i = 0; i < frame_ids_.size(); ++i)
    spins_.col(static_cast<Eigen::Index>(i)) =
        pinocchio::getFrameVelocity(*model_, *data_, frame_ids_[i], pinocchio::LOCAL_WORLD_ALIGNED)
            .angular();
  return spins_;
}

const Eigen::Matrix3Xd& LegKinematics::feet_and_spins(
    const Eigen::Ref<const Eigen::VectorXd>& joints,
    const Eigen::Ref<const Eigen::VectorXd>& joint_velocities) {
  spins(joints, joint_velocities);  // forwardKinematics at (q, v): the joints' placements too
  for (std::size_t i = 0; i < frame_ids_.size(); ++i)
    feet_.col(static_cast<Eigen::Index>(i)) =
        pinocchio::updateFramePlacement(*model_, *data_, frame_ids_[i]).translation();
  return feet_;
}

void foot_innovation(const NominalState& x, int i, const Eigen::Vector3d& measured,
                     const ErrorLayout& layout, Eigen::Ref<Eigen::Vector3d> residual,
                     Eigen::Ref<Eigen::MatrixXd> H) {
  const Eigen::Vector3d predicted = x.rotation.transpose() * (x.feet.col(i) - x.position);
  H.block<3, 3>(0, layout.p) = -x.rotation.transpose();
  H.block<3, 3>(0, layout.theta) = pinocchio::skew(predicted);
  H.block<3, 3>(0, layout.foot(i)) = x.rotation.transpose();
  residual = measured - predicted;
}

Eigen::MatrixXd touchdown_map(const NominalState& x, const Eigen::Vector3d& measured,
                              const ErrorLayout& layout) {
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3, layout.size);
  A.block<3, 3>(0, layout.p).setIdentity();
  A.block<3, 3>(0, layout.theta) = -x.rotation * pinocchio::skew(measured);
  return A;
}

}  // namespace lab::estimation
