// Stance.update (stance.py): Herzog 2016 §5.4's transitions between double and single support
// and the lifted leg's swing (Fig. 11).
#include "behaviours/stance.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace lab {

double smooth(double s) {
  s = std::clamp(s, 0.0, 1.0);
  return 0.5 - 0.5 * std::cos(EIGEN_PI * s);
}

void Stance::update(double t, const BehaviourModel& robot, const Eigen::Vector3d& /*command*/,
                    const Eigen::Array<bool, Eigen::Dynamic, 1>& /*touching*/, References& refs) {
  if (swinging || (swing_hz > 0.0 && !started && !pending)) {
    update_swing(t, robot, refs);
    return;
  }
  if (!started && pending) {
    pending = false;
    if (pending_stance != stance) {
      from = stance;
      stance = pending_stance;
      if (from != kDoubleSupport && pending_stance != kDoubleSupport) {
        // Single to the other single goes through double support.
        stance = kDoubleSupport;
        pending = true;
      }
      started = true;
      started_at = t;
    }
  }
  if (!started) return;
  const double elapsed = t - started_at;
  const bool done =
      from == kDoubleSupport ? to_single(elapsed, refs) : to_double(elapsed, from, refs);
  if (done) started = false;
}

bool Stance::to_single(double elapsed, References& refs) {
  const int leaving = 1 - stance;
  Eigen::Vector3d target = middle;
  target.head<2>() = ground.row(stance).head<2>().transpose();
  refs.com = middle + smooth(elapsed / kShiftS) * (target - middle);  // 1. shift
  const double unload = (elapsed - kShiftS) / kUnloadS;               // 2. unload
  refs.normal_force_max(leaving) =
      unload <= 0.0 ? kNormalMax : std::max(1.0 - unload, 0.0) * weight;
  const double lift = (elapsed - kShiftS - kUnloadS) / kLiftS;  // 3. lift
  if (lift <= 0.0) return false;
  refs.contact_active(leaving) = false;
  refs.sole_position.segment<3>(3 * leaving) = ground.row(leaving).transpose();
  refs.sole_position(3 * leaving + 2) += kLiftHeight * smooth(lift);
  return lift >= 1.0;
}

bool Stance::to_double(double elapsed, int on, References& refs) {
  const int landing = 1 - on;
  const double lower = elapsed / kLiftS;
  refs.sole_position.segment<3>(3 * landing) = ground.row(landing).transpose();
  refs.sole_position(3 * landing + 2) += kLiftHeight * (1.0 - smooth(lower));
  if (lower < 1.0) return false;
  refs.contact_active(landing) = true;
  const double load = (elapsed - kLiftS) / kUnloadS;
  refs.normal_force_max(landing) = load < 1.0 ? std::min(load, 1.0) * weight : kNormalMax;
  const double shift = (elapsed - kLiftS - kUnloadS) / kShiftS;
  Eigen::Vector3d over = middle;
  over.head<2>() = ground.row(on).head<2>().transpose();
  refs.com = over + smooth(shift) * (middle - over);
  return shift >= 1.0;
}

void Stance::update_swing(double t, const BehaviourModel& robot, References& refs) {
  if (stance == kDoubleSupport) return;
  const int leg = 1 - stance;
  if (!swinging) {
    swinging = true;
    swing_start = t;
    swing_frequency = swing_hz;
    lifted = robot.q.tail(robot.q.size() - 7);
    periods_done = 0;
    refs.leg_position = lifted;
    refs.leg_swinging(leg) = true;
  }
  const double hz = swing_frequency;
  const auto periods = static_cast<long>((t - swing_start) * hz);
  const bool stop = swing_hz != hz || pending;
  if (stop && periods > periods_done) {  // back in the lifted posture
    swinging = false;
    refs.leg_swinging(leg) = false;
    refs.leg_position = lifted;
    refs.leg_velocity.setZero();
    refs.leg_acceleration.setZero();
    return;
  }
  periods_done = periods;
  if (flexion[leg].size() != 2)
    throw std::runtime_error("stance: the swinging leg needs a hip and a knee flexion joint");
  const double w = 2.0 * EIGEN_PI * hz, phase = w * (t - swing_start);
  for (int k = 0; k < 2; ++k) {
    const int joint = flexion[leg][k];
    const double a = 0.5 * kSwingAmplitude[k] * bend(joint);
    refs.leg_position(joint) = lifted(joint) + a * (1.0 - std::cos(phase));
    refs.leg_velocity(joint) = a * w * std::sin(phase);
    refs.leg_acceleration(joint) = a * w * w * std::cos(phase);
  }
}

}  // namespace lab
