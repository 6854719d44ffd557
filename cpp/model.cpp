#include "model.hpp"

#include <pinocchio/algorithm/center-of-mass.hpp>
#include <pinocchio/algorithm/compute-all-terms.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/serialization/archive.hpp>
#include <pinocchio/serialization/model.hpp>
#include <stdexcept>

namespace lab {

std::unique_ptr<pinocchio::Model> load_model(const std::string& serialized_model) {
  auto model = std::make_unique<pinocchio::Model>();
  try {
    model->loadFromString(serialized_model);
  } catch (const std::exception& error) {
    throw std::invalid_argument(std::string("not a serialized pinocchio model: ") + error.what());
  }
  return model;
}

namespace {

std::unique_ptr<pinocchio::Model> model_from_string(const std::string& text) {
  auto model = load_model(text);
  if (model->joints.size() < 2 || model->joints[1].shortname() != "JointModelFreeFlyer")
    throw std::invalid_argument("the model needs a free-flyer root joint");
  return model;
}

}  // namespace

RobotModel::RobotModel(const std::string& serialized_model, std::vector<ContactSpec> contacts_)
    : model(model_from_string(serialized_model)),
      data(std::make_unique<pinocchio::Data>(*model)),
      contacts(std::move(contacts_)) {
  nq = model->nq;
  nv = model->nv;
  na = nv - BASE_DOF;
  mass = 0.0;
  for (const auto& inertia : model->inertias) mass += inertia.mass();
  nf = 0;
  for (const auto& contact : contacts) {
    if (!model->existFrame(contact.frame))
      throw std::invalid_argument("contact frame '" + contact.frame + "' is not in the model");
    frame_ids.push_back(model->getFrameId(contact.frame));
    force_starts.push_back(nf);
    nf += contact.force_dim();
  }
  nx = nv + nf;
  q = pinocchio::neutral(*model);
  v = Eigen::VectorXd::Zero(nv);
  M = Eigen::MatrixXd::Zero(nv, nv);
  h = Eigen::VectorXd::Zero(nv);
  Jc = Eigen::MatrixXd::Zero(nf, nv);
  Jc_dot_v = Eigen::VectorXd::Zero(nf);
  com.setZero();
  com_velocity.setZero();
  com_drift.setZero();
  Jcom = Eigen::MatrixXd::Zero(3, nv);
  centroidal_map.setZero(6, nv);
  base_rotation.setIdentity();
  contact_positions.assign(contacts.size(), Eigen::Vector3d::Zero());
  contact_rotations.assign(contacts.size(), Eigen::Matrix3d::Identity());
  frame_jacobian_.setZero(6, nv);
}

RobotModel::~RobotModel() = default;

std::vector<std::string> RobotModel::frame_names() const {
  std::vector<std::string> names;
  for (const auto& frame : model->frames) names.push_back(frame.name);
  return names;
}

Eigen::MatrixXd RobotModel::inertia_parameters() const {
  Eigen::MatrixXd out(static_cast<Eigen::Index>(model->inertias.size()), 10);
  for (std::size_t i = 0; i < model->inertias.size(); ++i)
    out.row(static_cast<Eigen::Index>(i)) = model->inertias[i].toDynamicParameters().transpose();
  return out;
}

void RobotModel::update(const Eigen::Ref<const Eigen::VectorXd>& q_,
                        const Eigen::Ref<const Eigen::VectorXd>& v_) {
  q = q_;
  v = v_;
  // M, nle, joint Jacobians, CoM with its Jacobian, the centroidal map, and the drift
  // accelerations (qdd = 0) of every joint, which give J̇v below.
  const pinocchio::Model& model = *this->model;
  pinocchio::Data& data = *this->data;
  // computeAllTerms sums the root's momentum rate into data.f[0] without resetting it (pinocchio
  // 4.1: data.dhg grows call by call): zeroed here, so that data.dhg is this state's.
  data.f[0].setZero();
  pinocchio::computeAllTerms(model, data, q, v);
  // computeAllTerms leaves data.acom at zero: the CoM's drift J̇_com v, from the joints' drift
  // accelerations it computed (its data.dhg gives the same to rounding, but the CoM it
  // recomputes is the Python model's to the last bit, which the gain schedule's LQR designs
  // on both sides read).
  pinocchio::centerOfMass(model, data, pinocchio::ACCELERATION, false);
  // computeAllTerms fills the upper triangle of M only: both triangles from it in one copy.
  M.triangularView<Eigen::Upper>() = data.M;
  M.triangularView<Eigen::StrictlyLower>() = data.M.transpose();
  h = data.nle;
  com = data.com[0];
  com_velocity = data.vcom[0];
  com_drift = data.acom[0];
  // The momentum rate at q̈ = 0 that computeAllTerms leaves in data.dhg (about the CoM, world
  // axes) includes the weight, −m g in its linear part: without it, it is Ȧ_G v (Herzog eq. 20).
  // A second pass over the joints (computeCentroidalMomentumTimeVariation) gives the same to
  // rounding (1e-13 of 50-130 on ANYmal and Talos at random states).
  centroidal_drift_ = data.dhg.toVector();
  centroidal_drift_.head<3>() += data.mass[0] * model.gravity.linear();
  Jcom = data.Jcom;
  centroidal_map = data.Ag;
  base_rotation = Eigen::Quaterniond(q.segment<4>(3)).toRotationMatrix();
  for (std::size_t i = 0; i < contacts.size(); ++i) {
    const auto fid = frame_ids[i];
    // The contact frames' placements only (ANYmal's model has 161 frames; the frame Jacobians and
    // accelerations below read the joints' placements, not data.oMf).
    const auto& placement = pinocchio::updateFramePlacement(model, data, fid);
    contact_positions[i] = placement.translation();
    contact_rotations[i] = placement.rotation();
    const int start = force_starts[i];
    frame_jacobian_.setZero();
    if (contacts[i].kind == ContactKind::point) {
      const auto frame = pinocchio::LOCAL_WORLD_ALIGNED;
      pinocchio::getFrameJacobian(model, data, fid, frame, frame_jacobian_);
      Jc.middleRows<3>(start) = frame_jacobian_.topRows<3>();
      Jc_dot_v.segment<3>(start) =
          pinocchio::getFrameClassicalAcceleration(model, data, fid, frame).linear();
    } else {
      const auto frame = pinocchio::LOCAL;
      pinocchio::getFrameJacobian(model, data, fid, frame, frame_jacobian_);
      Jc.middleRows<6>(start) = frame_jacobian_;
      Jc_dot_v.segment<6>(start) =
          pinocchio::getFrameClassicalAcceleration(model, data, fid, frame).toVector();
    }
  }
}

void RobotModel::joint_torques(const Eigen::Ref<const Eigen::VectorXd>& x,
                               Eigen::Ref<Eigen::VectorXd> tau) const {
  tau.noalias() = M.bottomRows(na) * x.head(nv);
  tau += h.tail(na);
  tau.noalias() -= Jc.rightCols(na).transpose() * x.tail(nf);
}

void RobotModel::force_rows_of(const Eigen::Array<bool, Eigen::Dynamic, 1>& flags,
                               Eigen::Array<bool, Eigen::Dynamic, 1>& rows) const {
  rows.resize(nf);
  for (std::size_t i = 0; i < contacts.size(); ++i)
    rows.segment(force_starts[i], contacts[i].force_dim()).setConstant(flags[i]);
}

}  // namespace lab
