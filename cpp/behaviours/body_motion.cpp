// HeightStep.update and ForwardShift.update (body_motion.py): Hutter 2014 Sim5, Exp6/Exp7.
#include "behaviours/body_motion.hpp"

namespace lab {

void HeightStep::update(double t, const BehaviourModel& /*robot*/,
                        const Eigen::Vector3d& /*command*/,
                        const Eigen::Array<bool, Eigen::Dynamic, 1>& /*touching*/,
                        References& refs) {
  const double drop = clock.since(t) >= kMotionHold ? kHeightStep : 0.0;
  refs.com = com - Eigen::Vector3d(0.0, 0.0, drop);
  refs.base_height = height - drop;
}

void ForwardShift::update(double t, const BehaviourModel& /*robot*/,
                          const Eigen::Vector3d& /*command*/,
                          const Eigen::Array<bool, Eigen::Dynamic, 1>& /*touching*/,
                          References& refs) {
  const Eigen::Vector3d sigma = min_jerk((clock.since(t) - kMotionHold) / kShiftTime);
  refs.com = com + Eigen::Vector3d(kShift * sigma(0), 0.0, 0.0);
  refs.com_velocity = Eigen::Vector3d(kShift * sigma(1) / kShiftTime, 0.0, 0.0);
}

}  // namespace lab
