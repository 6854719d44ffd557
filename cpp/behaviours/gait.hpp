// Gait scheduler: when each leg lifts off, swings and lands (Raiola §3.1, Fig. 4-5); mirrors
// lab/controller/behaviours/gait.py (GaitScheduler, Leg, LegEvent), whose docstring explains the
// state machine. Legs are given by index; each carries its role's lift-off offset.
#pragma once

#include <vector>

namespace lab {

constexpr int kMaxLegs = 8;  // the scheduler's bound on legs (walking has four)

/// Where a leg is in its cycle (gait.py LegState).
enum class LegState { kStance, kSwing, kReaching };

/// One leg's state machine (gait.py Leg); `offset` is its role's lift-off phase in the gait.
struct Leg {
  double offset = 0.0;
  LegState state = LegState::kStance;
  double since = 0.0;           // time of the last lift-off or touchdown
  double swing_duration = 0.0;  // planned duration of the current swing
  bool unloading = false;       // unload_start is not None
  double unload_start = 0.0;    // start of the unloading ramp before lift-off
  long last_cycle = -1;         // cycle index of the last lift-off: one lift-off per cycle
};

/// A lift-off or touchdown of leg `leg` (gait.py LegEvent; the time is the tick's).
struct LegEvent {
  int leg;
  bool liftoff;  // else a touchdown
};

/// Per-leg state machines driven by one phase clock (gait.py GaitScheduler).
class GaitScheduler {
 public:
  std::vector<Leg> legs;
  double duty_factor = 0.5;
  double cycle_time = 1.0;
  double phase = 0.0;
  double t = 0.0;

  double ramp_time() const { return 0.05 * cycle_time; }
  double swing_time() const { return (1.0 - duty_factor) * cycle_time; }
  /// Move the clock to time t and every leg's state machine; `events` gets the lift-offs and
  /// touchdowns (cleared first).
  void advance(double t, const bool* touching, std::vector<LegEvent>& events);
  /// Fraction of full load leg i may carry: 0 in the air, ramps at both ends of stance.
  double load(int i, double t) const;

 private:
  void local(const Leg& leg, long& cycle, double& phase) const;
  bool may_unload(int i) const;
  bool liftoff(int i, double t);
};

}  // namespace lab
