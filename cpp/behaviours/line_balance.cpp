// Balance about the foot line (line_balance.py line_balance_offset).
#include "behaviours/line_balance.hpp"

#include <algorithm>
#include <pinocchio/spatial/explog.hpp>

namespace lab {

Eigen::Vector3d line_balance_offset(const BehaviourModel& robot,
                                    const Eigen::Matrix3d& base_rotation_ref,
                                    const Eigen::Matrix3d& inertia, const LineBalanceGains& gains) {
  const Eigen::Vector3d a = robot.contact_positions.row(0).transpose();
  const Eigen::Vector3d b = robot.contact_positions.row(1).transpose();
  const Eigen::Vector3d u = (b - a).normalized();
  const Eigen::Vector3d across = u.cross(Eigen::Vector3d::UnitZ());  // L̇_u = m g (c − p)·across
  const Eigen::Vector3d c = robot.com, p = 0.5 * (a + b);
  const Eigen::Matrix<double, 6, 1> momentum = robot.centroidal_momentum();
  const Eigen::Vector3d L =
      momentum.tail<3>() + (c - p).cross(momentum.head<3>());  // about the line's midpoint
  const Eigen::Matrix3d rotation = robot.base_rotation * base_rotation_ref.transpose();
  const Eigen::Vector3d rotation_error = pinocchio::log3(rotation);  // world axes
  const double inertia_u = u.dot(inertia * u);
  const double weight = robot.mass * robot.gravity.norm();
  const double w = gains.omega, zeta = gains.damping;
  const double d =
      -(2.0 * zeta * w * u.dot(L) + w * w * inertia_u * u.dot(rotation_error)) / weight;
  return std::clamp(d, -gains.max_offset, gains.max_offset) * across;
}

}  // namespace lab
