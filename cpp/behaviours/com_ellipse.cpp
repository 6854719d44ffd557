// ComEllipse.update (com_ellipse.py): the ellipse of Kim 2016 Fig. 6b, balanced about the line.
#include "behaviours/com_ellipse.hpp"

#include <algorithm>
#include <cmath>

namespace lab {

void ComEllipse::update(double t, const BehaviourModel& robot, const Eigen::Vector3d& command,
                        const Eigen::Array<bool, Eigen::Dynamic, 1>& touching, References& refs) {
  const double since = clock.since(t);
  const double phase = 2.0 * EIGEN_PI / kEllipsePeriod * std::max(since - kEllipseHold, 0.0);
  const double rate = 2.0 * EIGEN_PI / kEllipsePeriod * (since >= kEllipseHold ? 1.0 : 0.0);
  const double s = std::sin(phase), c = std::cos(phase);
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  com_on_line = centre + kEllipseAlong * s * along;
  com_on_line += kEllipseUp * (c - 1.0) * z;
  Balance::update(t, robot, command, touching, refs);  // the lean off the foot line
  refs.com_velocity = rate * (kEllipseAlong * c * along - kEllipseUp * s * z);
}

}  // namespace lab
