// Inequality rows C x <= d (mirrors lab/controller/constraints.py): friction, cop, cop_inner,
// sole_torsion, torque_limits, joint_limits.
#pragma once

#include <map>
#include <memory>
#include <string>

#include "model.hpp"
#include "references.hpp"

namespace lab {

/// A producer of inequality rows C x <= d.
class Constraint {
 public:
  virtual ~Constraint() = default;
  virtual void compute(const RobotModel& robot, const References& refs) = 0;

  Eigen::MatrixXd C;
  Eigen::VectorXd d;

 protected:
  void reset(const RobotModel& robot, Eigen::Index n);
};

/// Friction and normal-force bounds shared by every contact (constraints.py ContactLimits).
struct ContactLimits {
  double friction = 0.8;
  double normal_min = 0.0;
  double normal_max = 5000.0;
};

using ConstraintRegistry = std::map<std::string, std::unique_ptr<Constraint>>;

/// The constraints of a robot: friction, torque_limits, joint_limits, and with flat feet cop,
/// cop_inner and sole_torsion.
ConstraintRegistry make_constraints(const RobotModel& robot, const ContactLimits& limits,
                                    const Eigen::VectorXd& torque_limits,
                                    const Eigen::VectorXd& lower, const Eigen::VectorXd& upper);

// Setters of the constraints' parameters (constraints.cpp); names as in the registry.
/// Of friction or sole_torsion (both read the contact limits, as in constraints.py).
void set_contact_limits(Constraint& constraint, const ContactLimits& limits);
void set_torque_limits(Constraint& torque_limits, const Eigen::VectorXd& limits);
void set_joint_limits(Constraint& joint_limits, const Eigen::VectorXd& lower,
                      const Eigen::VectorXd& upper);

}  // namespace lab
