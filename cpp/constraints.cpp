// Inequality rows C x <= d (lab/controller/constraints.py): friction, cop, cop_inner,
// sole_torsion, torque_limits, joint_limits.
#include "constraints.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "tasks/base.hpp"

namespace lab {

void Constraint::reset(const RobotModel& robot, Eigen::Index n) {
  C.setZero(n, robot.nx);
  d.setZero(n);
}

namespace {

/// Inner friction pyramid and normal-force bounds per contact (Raiola C_fc); a contact that is
/// not active carries no force at all.
class FrictionConstraint : public Constraint {
 public:
  explicit FrictionConstraint(const ContactLimits& limits) : limits(limits) {}

  void compute(const RobotModel& robot, const References& refs) override {
    const double mu = std::sqrt(0.5) * limits.friction;
    const bool per_contact = refs.normal_force_max.size() > 0;
    Eigen::Index n = 0;
    for (std::size_t i = 0; i < robot.contacts.size(); ++i)
      n += refs.contact_active[i] ? 6 : 2 * robot.contacts[i].force_dim();
    reset(robot, n);
    Eigen::Index row = 0;
    for (std::size_t i = 0; i < robot.contacts.size(); ++i) {
      const Eigen::Index col = robot.nv + robot.force_starts[i];
      if (refs.contact_active[i]) {
        for (int tangent = 0; tangent < 2; ++tangent) {
          C(row + 2 * tangent, col + tangent) = 1.0;
          C(row + 2 * tangent, col + 2) = -mu;
          C(row + 2 * tangent + 1, col + tangent) = -1.0;
          C(row + 2 * tangent + 1, col + 2) = -mu;
        }
        C(row + 4, col + 2) = -1.0;
        d[row + 4] = -limits.normal_min;
        C(row + 5, col + 2) = 1.0;
        d[row + 5] = per_contact ? refs.normal_force_max[i] : limits.normal_max;
        row += 6;
      } else {
        const int dim = robot.contacts[i].force_dim();
        C.block(row, col, dim, dim).setIdentity();
        C.block(row + dim, col, dim, dim) = -Eigen::MatrixXd::Identity(dim, dim);
        row += 2 * dim;
      }
    }
  }

  ContactLimits limits;
};

/// Each flat foot in support and the column of its wrench's first entry in x (constraints.py
/// _soles_in_support).
using Soles = std::vector<std::pair<const ContactSpec*, Eigen::Index>>;

void soles_in_support(const RobotModel& robot, const References& refs, Soles& soles) {
  soles.clear();  // no allocation once it has grown
  for (std::size_t i = 0; i < robot.contacts.size(); ++i)
    if (robot.contacts[i].kind == ContactKind::flat && refs.contact_active[i])
      soles.emplace_back(&robot.contacts[i], robot.nv + robot.force_starts[i]);
}

/// Centre of pressure inside the sole rectangle, for flat feet (Herzog §4.1):
/// |τ_x| <= W f_z and |τ_y| <= L f_z with the wrench in the sole frame, W and L scaled by
/// `scale` (cop_inner keeps a margin at the edges: InnerCopConstraint).
class CopConstraint : public Constraint {
 public:
  explicit CopConstraint(double scale = 1.0) : scale(scale) {}

  void compute(const RobotModel& robot, const References& refs) override {
    soles_in_support(robot, refs, soles_);
    reset(robot, 4 * static_cast<Eigen::Index>(soles_.size()));
    Eigen::Index row = 0;
    for (const auto& [contact, col] : soles_) {
      const std::pair<int, double> axes[2] = {{3, scale * contact->half_width},
                                              {4, scale * contact->half_length}};
      for (int k = 0; k < 2; ++k) {
        const auto [torque_axis, half] = axes[k];
        C(row + 2 * k, col + torque_axis) = 1.0;
        C(row + 2 * k, col + 2) = -half;
        C(row + 2 * k + 1, col + torque_axis) = -1.0;
        C(row + 2 * k + 1, col + 2) = -half;
      }
      row += 4;
    }
  }

  double scale;

 private:
  Soles soles_;
};

/// The fraction of each half size of a sole that cop_inner keeps free (INNER_COP_MARGIN).
constexpr double kInnerCopMargin = 0.15;

/// Torsional friction of a flat sole in support: |τ_z| <= μ r f_z, r = (√2/2) min(L, W), sole
/// frame (SoleTorsionConstraint).
class SoleTorsionConstraint : public Constraint {
 public:
  explicit SoleTorsionConstraint(const ContactLimits& limits) : limits(limits) {}

  void compute(const RobotModel& robot, const References& refs) override {
    soles_in_support(robot, refs, soles_);
    reset(robot, 2 * static_cast<Eigen::Index>(soles_.size()));
    Eigen::Index row = 0;
    for (const auto& [contact, col] : soles_) {
      const double radius = std::sqrt(0.5) * std::min(contact->half_length, contact->half_width);
      C(row, col + 5) = 1.0;
      C(row, col + 2) = -limits.friction * radius;
      C(row + 1, col + 5) = -1.0;
      C(row + 1, col + 2) = -limits.friction * radius;
      row += 2;
    }
  }

  ContactLimits limits;

 private:
  Soles soles_;
};

/// |τ| <= τ_max through τ = M_a q̈ + h_a − J_aᵀ F (Herzog eqs. 14, 16).
class TorqueLimitConstraint : public Constraint {
 public:
  explicit TorqueLimitConstraint(Eigen::VectorXd limits) : limits(std::move(limits)) {}

  void compute(const RobotModel& robot, const References&) override {
    const Eigen::Index na = robot.na;
    C.resize(2 * na, robot.nx);
    d.resize(2 * na);
    C.topLeftCorner(na, robot.nv) = robot.M.bottomRows(na);
    C.topRightCorner(na, robot.nf) = -robot.Jc.rightCols(na).transpose();
    C.bottomRows(na) = -C.topRows(na);
    d.head(na) = limits - robot.h.tail(na);
    d.tail(na) = limits + robot.h.tail(na);
  }

  Eigen::VectorXd limits;
};

/// Joint-acceleration bounds that stop each joint at its position limit: within the horizon T,
/// q + q̇ T + ½ q̈ T² stays inside [q_min, q_max] (Hutter Table 6).
class JointLimitConstraint : public Constraint {
 public:
  JointLimitConstraint(Eigen::VectorXd lower, Eigen::VectorXd upper)
      : lower(std::move(lower)), upper(std::move(upper)) {}

  void compute(const RobotModel& robot, const References&) override {
    const Eigen::Index na = robot.na;
    const double T = horizon;
    reset(robot, 2 * na);
    C.block(0, BASE_DOF, na, na).setIdentity();
    C.block(na, BASE_DOF, na, na) = -Eigen::MatrixXd::Identity(na, na);
    const auto q = robot.q.tail(na), dq = robot.v.tail(na);
    d.head(na) = 2.0 * (upper - q - dq * T) / (T * T);
    d.tail(na) = -(2.0 * (lower - q - dq * T) / (T * T));
  }

  Eigen::VectorXd lower, upper;
  double horizon = 0.05;
};

}  // namespace

ConstraintRegistry make_constraints(const RobotModel& robot, const ContactLimits& limits,
                                    const Eigen::VectorXd& torque_limits,
                                    const Eigen::VectorXd& lower, const Eigen::VectorXd& upper) {
  ConstraintRegistry constraints;
  constraints["friction"] = std::make_unique<FrictionConstraint>(limits);
  constraints["torque_limits"] = std::make_unique<TorqueLimitConstraint>(torque_limits);
  constraints["joint_limits"] = std::make_unique<JointLimitConstraint>(lower, upper);
  for (const auto& contact : robot.contacts)
    if (contact.kind == ContactKind::flat) {
      constraints["cop"] = std::make_unique<CopConstraint>();
      constraints["cop_inner"] = std::make_unique<CopConstraint>(1.0 - kInnerCopMargin);
      constraints["sole_torsion"] = std::make_unique<SoleTorsionConstraint>(limits);
      break;
    }
  return constraints;
}

void set_contact_limits(Constraint& constraint, const ContactLimits& limits) {
  if (auto* torsion = dynamic_cast<SoleTorsionConstraint*>(&constraint))
    torsion->limits = limits;
  else
    dynamic_cast<FrictionConstraint&>(constraint).limits = limits;
}

void set_torque_limits(Constraint& torque_limits, const Eigen::VectorXd& limits) {
  dynamic_cast<TorqueLimitConstraint&>(torque_limits).limits = limits;
}

void set_joint_limits(Constraint& joint_limits, const Eigen::VectorXd& lower,
                      const Eigen::VectorXd& upper) {
  auto& constraint = dynamic_cast<JointLimitConstraint&>(joint_limits);
  constraint.lower = lower;
  constraint.upper = upper;
}

}  // namespace lab
