// The constant-time-to-velocity-reversal footstep planner of Kim 2016 §V (eqs. 18-24), one
// horizontal axis at a time; mirrors lab/controller/behaviours/pipm.py, whose docstring derives
// the closed form of the PIPM on a planar height surface (eq. 24 with h'' = 0 is the linear
// inverted pendulum with omega^2 = g / h(x_p)). `predicted_path` (the drawn prediction) and
// `scaled_reversal_time` stay in Python.
#pragma once

namespace lab {

/// The CoM height surface h(x) = height + slope (x - origin) (pipm.py LinearSurface).
struct LinearSurface {
  double height = 0.0;
  double slope = 0.0;
  double origin = 0.0;
  /// h(x) (m).
  double at(double x) const { return height + slope * (x - origin); }
};

/// Time (s), CoM position (m) and velocity (m/s) along one horizontal axis (PipmState).
struct PipmState {
  double t = 0.0, x = 0.0, xd = 0.0;
};

/// The planner's answer (PlannedStep): the next foot and the states predicted on the way.
struct PlannedStep {
  double foot = 0.0;
  PipmState switching, post_impact, reversal;
};

/// omega (1/s) of the PIPM over a foot at `foot` (pipm.py frequency).
double pipm_frequency(double foot, const LinearSurface& surface);

/// The PIPM's state `duration` s after `state` over a foot at `foot` (state_after).
PipmState state_after(const PipmState& state, double foot, double duration,
                      const LinearSurface& surface);

/// The first time (s) at which |xd| = `speed`; 0 if already that fast, infinity if never
/// (time_to_speed).
double time_to_speed(const PipmState& state, double foot, double speed,
                     const LinearSurface& surface);

/// The foot within `reach` whose velocity is `velocity` `reversal_time` after `post_impact`
/// (reversal_foot: closed form on a level surface, bisection to `tolerance` on a slope).
double reversal_foot(const PipmState& post_impact, double reversal_time,
                     const LinearSurface& surface, double reach, double tolerance, double velocity);

/// The switching state, the post-impact state and the reversing foot (plan_step).
PlannedStep plan_step(const PipmState& now, double stance_foot, double switch_in,
                      double reversal_time, const LinearSurface& surface,
                      double impact_velocity_change, double reach, double velocity,
                      double tolerance);

/// Kim §V-2's lateral timing rules: the switch cut at max_speed, or lengthened to min_speed
/// (lateral_switch_time).
double lateral_switch_time(const PipmState& now, double stance_foot, double switch_in,
                           const LinearSurface& surface, double max_speed, double min_speed,
                           double shortest, double longest);

}  // namespace lab
