// Squat.update (squat.py): c(t) = c₀ + A sin(2π t / period) after HOLD s, its velocity as the
// momentum reference and its acceleration fed forward (Herzog eq. 22).
#include "behaviours/squat.hpp"

#include <algorithm>
#include <cmath>

namespace lab {

void Squat::update(double t, const BehaviourModel& /*robot*/, const Eigen::Vector3d& /*command*/,
                   const Eigen::Array<bool, Eigen::Dynamic, 1>& /*touching*/, References& refs) {
  const double since = clock.since(t);
  const double phase = std::max(since - kSquatHold, 0.0);
  const double omega = 2.0 * EIGEN_PI / period;
  const double active = since >= kSquatHold ? 1.0 : 0.0;
  refs.com = centre + amplitude * std::sin(omega * phase);
  refs.com_velocity = amplitude * omega * std::cos(omega * phase) * active;
  refs.com_acceleration = -amplitude * omega * omega * std::sin(omega * phase) * active;
}

}  // namespace lab
