// Balance.update (balance.py).
#include "behaviours/balance.hpp"

namespace lab {

void Balance::update(double /*t*/, const BehaviourModel& robot, const Eigen::Vector3d& /*command*/,
                     const Eigen::Array<bool, Eigen::Dynamic, 1>& /*touching*/, References& refs) {
  if (on_line)
    refs.com = com_on_line + line_balance_offset(robot, refs.base_rotation, inertia, line_gains);
}

}  // namespace lab
