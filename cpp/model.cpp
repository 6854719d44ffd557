#include "model.hpp"

#include <pinocchio/algorithm/center-of-mass.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/multibody/visitor.hpp>
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

// The terms of the tick in one pass: pinocchio's computeAllTerms (pinocchio 4.1,
// compute-all-terms.hxx) step for step, without what no reader of the model takes from it: the
// time variations J̇ and Ȧ_G with the inertias' rates they are built from (dJ, dAg, doYcrb), the
// bodies' momenta and CoMs (data.h, data.com[i]: centerOfMass redoes the CoM and its velocity),
// the energies and the gravity torque g. Each kept quantity is computed by the same expressions
// in the same order as there, so M, nle, J, Ag and the rest are computeAllTerms' own (the Python
// model calls computeAllTerms).
struct TermsForwardStep : pinocchio::fusion::JointUnaryVisitorBase<TermsForwardStep> {
  using ArgsType = boost::fusion::vector<const pinocchio::Model&, pinocchio::Data&,
                                         const Eigen::VectorXd&, const Eigen::VectorXd&>;

  template <typename JointModel>
  static void algo(const pinocchio::JointModelBase<JointModel>& jmodel,
                   pinocchio::JointDataBase<typename JointModel::JointDataDerived>& jdata,
                   const pinocchio::Model& model, pinocchio::Data& data, const Eigen::VectorXd& q,
                   const Eigen::VectorXd& v) {
    using ColsBlock = typename pinocchio::SizeDepType<JointModel::NV>::template ColsReturn<
        pinocchio::Data::Matrix6x>::Type;
    const pinocchio::JointIndex i = jmodel.id();
    const pinocchio::JointIndex parent = model.parents[i];
    jmodel.calc(jdata.derived(), q, v);
    data.liMi[i] = model.jointPlacements[i] * jdata.M();
    data.v[i] = jdata.v();
    if (parent > 0) {
      data.oMi[i] = data.oMi[parent] * data.liMi[i];
      data.v[i] += data.liMi[i].actInv(data.v[parent]);
    } else {
      data.oMi[i] = data.liMi[i];
    }
    data.oYcrb[i] = data.oMi[i].act(model.inertias[i]);
    ColsBlock J_cols = jmodel.jointCols(data.J);
    J_cols = data.oMi[i].act(jdata.S());
    data.a_gf[i] = data.a[i] = jdata.c() + (data.v[i] ^ jdata.v());
    if (parent > 0) data.a[i] += data.liMi[i].actInv(data.a[parent]);
    data.a_gf[i] += data.liMi[i].actInv(data.a_gf[parent]);
    data.f[i] = model.inertias[i] * data.a_gf[i] + data.v[i].cross(model.inertias[i] * data.v[i]);
  }
};

struct TermsBackwardStep : pinocchio::fusion::JointUnaryVisitorBase<TermsBackwardStep> {
  using ArgsType = boost::fusion::vector<const pinocchio::Model&, pinocchio::Data&>;

  template <typename JointModel>
  static void algo(const pinocchio::JointModelBase<JointModel>& jmodel,
                   pinocchio::JointDataBase<typename JointModel::JointDataDerived>& jdata,
                   const pinocchio::Model& model, pinocchio::Data& data) {
    using ColsBlock = typename pinocchio::SizeDepType<JointModel::NV>::template ColsReturn<
        pinocchio::Data::Matrix6x>::Type;
    const pinocchio::JointIndex i = jmodel.id();
    const pinocchio::JointIndex parent = model.parents[i];
    ColsBlock J_cols = jmodel.jointCols(data.J);
    ColsBlock Ag_cols = jmodel.jointCols(data.Ag);
    pinocchio::motionSet::inertiaAction(data.oYcrb[i], J_cols, Ag_cols);
    data.M.block(jmodel.idx_v(), jmodel.idx_v(), jmodel.nv(), data.nvSubtree[i]).noalias() =
        J_cols.transpose() * data.Ag.middleCols(jmodel.idx_v(), data.nvSubtree[i]);
    jmodel.jointVelocitySelector(data.nle) = jdata.S().transpose() * data.f[i];
    data.oYcrb[parent] += data.oYcrb[i];
    data.f[parent] += data.liMi[i].act(data.f[i]);
  }
};

/// M (upper triangle), nle, the joint Jacobians J, the joints' placements, velocities and drift
/// accelerations (q̈ = 0), the centroidal map Ag with the CoM of the whole body, Jcom and the
/// momentum rate dhg (weight included), as computeAllTerms gives them (TermsForwardStep).
void tick_terms(const pinocchio::Model& model, pinocchio::Data& data, const Eigen::VectorXd& q,
                const Eigen::VectorXd& v) {
  data.v[0].setZero();
  data.a[0].setZero();
  data.a_gf[0] = -model.gravity;
  data.oYcrb[0].setZero();
  // computeAllTerms leaves the root's force to its backward pass's sums (pinocchio 4.1: dhg
  // then grows call by call); here it starts from zero.
  data.f[0].setZero();
  for (pinocchio::JointIndex i = 1; i < static_cast<pinocchio::JointIndex>(model.njoints); ++i)
    TermsForwardStep::run(model.joints[i], data.joints[i],
                          TermsForwardStep::ArgsType(model, data, q, v));
  for (auto i = static_cast<pinocchio::JointIndex>(model.njoints - 1); i > 0; --i)
    TermsBackwardStep::run(model.joints[i], data.joints[i],
                           TermsBackwardStep::ArgsType(model, data));
  data.mass[0] = data.oYcrb[0].mass();
  data.com[0] = data.oYcrb[0].lever();
  const auto Ag_lin = data.Ag.middleRows<3>(pinocchio::Force::LINEAR);
  auto Ag_ang = data.Ag.middleRows<3>(pinocchio::Force::ANGULAR);
  for (Eigen::Index i = 0; i < model.nv; ++i) Ag_ang.col(i) += Ag_lin.col(i).cross(data.com[0]);
  data.dhg = data.f[0];
  data.dhg.angular() += data.dhg.linear().cross(data.com[0]);
  data.M.diagonal() += model.armature;
  data.Jcom = data.Ag.middleRows<3>(pinocchio::Force::LINEAR) / data.mass[0];
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
  tick_terms(model, data, q, v);
  // tick_terms (as computeAllTerms) leaves data.acom at zero: the CoM's drift J̇_com v, from the
  // joints' drift accelerations it computed (its data.dhg gives the same to rounding, but the CoM
  // it recomputes is the Python model's to the last bit, which the gain schedule's LQR designs on
  // both sides read).
  pinocchio::centerOfMass(model, data, pinocchio::ACCELERATION, false);
  // tick_terms fills the upper triangle of M only: both triangles from it in one copy.
  M.triangularView<Eigen::Upper>() = data.M;
  M.triangularView<Eigen::StrictlyLower>() = data.M.transpose();
  h = data.nle;
  com = data.com[0];
  com_velocity = data.vcom[0];
  com_drift = data.acom[0];
  // The momentum rate at q̈ = 0 that tick_terms leaves in data.dhg (about the CoM, world
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
