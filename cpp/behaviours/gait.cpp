#include "behaviours/gait.hpp"

#include <algorithm>
#include <cmath>

namespace lab {
namespace {
constexpr double kCatchUp = 0.2;         // gait.py CATCH_UP
constexpr double kMinStanceRamps = 2.0;  // gait.py MIN_STANCE_RAMPS
constexpr double kReachFraction = 0.5;   // gait.py REACH_FRACTION
}  // namespace

void GaitScheduler::local(const Leg& leg, long& cycle, double& phase_in_cycle) const {
  const double shifted = phase - leg.offset;
  const double floor = std::floor(shifted);
  cycle = static_cast<long>(floor);
  phase_in_cycle = shifted - floor;
}

bool GaitScheduler::may_unload(int i) const {
  const double offset = legs[i].offset;
  for (std::size_t j = 0; j < legs.size(); ++j) {
    if (static_cast<int>(j) == i) continue;
    const Leg& other = legs[j];
    if (!((other.state == LegState::kStance && !other.unloading) || other.offset == offset))
      return false;
  }
  return true;
}

void GaitScheduler::advance(double t_now, const bool* touching, std::vector<LegEvent>& events) {
  // The clock waits for a late foot: it stands still while a leg reaches (gait.py).
  const bool late = std::any_of(legs.begin(), legs.end(),
                                [](const Leg& leg) { return leg.state == LegState::kReaching; });
  if (!late) phase += (t_now - t) / cycle_time;
  t = t_now;
  events.clear();
  const std::size_t n = legs.size();
  bool stance[kMaxLegs] = {};
  for (std::size_t i = 0; i < n; ++i) stance[i] = legs[i].state == LegState::kStance;
  // Touchdowns first, so that every lift-off this tick sees the same legs on the ground.
  for (std::size_t i = 0; i < n; ++i) {
    if (stance[i]) continue;
    Leg& leg = legs[i];
    const double elapsed = t_now - leg.since;
    const bool landed = touching[i] && elapsed >= 0.5 * leg.swing_duration;
    const bool gave_up = elapsed >= (1.0 + kReachFraction) * leg.swing_duration;
    if (landed || gave_up) {
      leg.state = LegState::kStance;
      leg.since = t_now;
      events.push_back({static_cast<int>(i), false});
    } else if (elapsed >= leg.swing_duration) {
      leg.state = LegState::kReaching;
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (stance[i] && liftoff(static_cast<int>(i), t_now))
      events.push_back({static_cast<int>(i), true});
}

bool GaitScheduler::liftoff(int i, double t_now) {
  Leg& leg = legs[i];
  long cycle;
  double phase_in_cycle;
  local(leg, cycle, phase_in_cycle);
  const double time_to_liftoff = (1.0 - phase_in_cycle) * cycle_time;
  const double window = 1.0 - duty_factor;
  const double ramp = ramp_time();
  if (!leg.unloading) {
    const bool due = phase_in_cycle < kCatchUp * window && cycle > leg.last_cycle;
    const bool rested = t_now - leg.since >= kMinStanceRamps * ramp;
    const bool soon = time_to_liftoff <= ramp || due;
    if (rested && soon && may_unload(i)) {
      leg.unloading = true;
      leg.unload_start = t_now;
    }
    return false;
  }
  if (t_now - leg.unload_start < ramp - 1e-9) return false;
  // Unloaded: lift off now and swing to the end of this leg's swing window.
  if (phase_in_cycle >= window) {  // unloaded ahead of the window: that is its next cycle
    cycle += 1;
    phase_in_cycle = 0.0;
  }
  leg.state = LegState::kSwing;
  leg.since = t_now;
  leg.unloading = false;
  leg.last_cycle = cycle;
  leg.swing_duration = std::max((window - phase_in_cycle) * cycle_time, 0.5 * swing_time());
  return true;
}

double GaitScheduler::load(int i, double t_now) const {
  const Leg& leg = legs[i];
  if (leg.state != LegState::kStance) return 0.0;
  const double ramp = ramp_time();
  const double up = (t_now - leg.since) / ramp;
  const double down = leg.unloading ? 1.0 - (t_now - leg.unload_start) / ramp : 1.0;
  return std::min(1.0, std::max(0.0, std::min(up, down)));
}

}  // namespace lab
