#include "behaviours/pipm.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lab {
namespace {
constexpr double kGravity = 9.81;  // pipm.py GRAVITY
}  // namespace

// pipm.py frequency: eq. 24 on a plane is xdd = g / h(x_p) (x - x_p).
double pipm_frequency(double foot, const LinearSurface& surface) {
  return std::sqrt(kGravity / surface.at(foot));
}

// pipm.py state_after: x(t) - x_p = (x0 - x_p) cosh(wt) + xd0 / w sinh(wt).
PipmState state_after(const PipmState& state, double foot, double duration,
                      const LinearSurface& surface) {
  const double w = pipm_frequency(foot, surface);
  const double c = std::cosh(w * duration), s = std::sinh(w * duration);
  const double d = state.x - foot;
  return {state.t + duration, foot + d * c + state.xd / w * s, d * w * s + state.xd * c};
}

// pipm.py time_to_speed: with u = e^{wt}, xd = a u + b / u; the smallest root u >= 1 of
// a u^2 -+ speed u + b = 0.
double time_to_speed(const PipmState& state, double foot, double speed,
                     const LinearSurface& surface) {
  if (std::abs(state.xd) >= speed) return 0.0;
  const double w = pipm_frequency(foot, surface);
  const double a = 0.5 * (state.xd + w * (state.x - foot));
  const double b = 0.5 * (state.xd - w * (state.x - foot));
  double u = std::numeric_limits<double>::infinity();
  const auto consider = [&u](double root) {
    if (root >= 1.0) u = std::min(u, root);
  };
  for (const double v : {speed, -speed}) {
    if (a == 0.0) {
      consider(b / v);
      continue;
    }
    const double disc = v * v - 4.0 * a * b;
    if (disc >= 0.0) {
      consider((v + std::sqrt(disc)) / (2.0 * a));
      consider((v - std::sqrt(disc)) / (2.0 * a));
    }
  }
  return std::log(u) / w;
}

// pipm.py reversal_foot.
double reversal_foot(const PipmState& post_impact, double reversal_time,
                     const LinearSurface& surface, double reach, double tolerance,
                     double velocity) {
  double lo = post_impact.x - reach, hi = post_impact.x + reach;
  if (surface.slope == 0.0) {
    const double w = pipm_frequency(0.0, surface);
    const double c = std::cosh(w * reversal_time), s = std::sinh(w * reversal_time);
    const double foot = post_impact.x + (post_impact.xd * c - velocity) / (w * s);
    return std::min(std::max(foot, lo), hi);
  }
  const auto velocity_at_reversal = [&](double foot) {
    return state_after(post_impact, foot, reversal_time, surface).xd - velocity;
  };
  if (velocity_at_reversal(lo) <= 0.0) return lo;
  if (velocity_at_reversal(hi) >= 0.0) return hi;
  while (hi - lo > tolerance) {
    const double middle = 0.5 * (lo + hi);
    if (velocity_at_reversal(middle) > 0.0) {
      lo = middle;
    } else {
      hi = middle;
    }
  }
  return 0.5 * (lo + hi);
}

// pipm.py plan_step.
PlannedStep plan_step(const PipmState& now, double stance_foot, double switch_in,
                      double reversal_time, const LinearSurface& surface,
                      double impact_velocity_change, double reach, double velocity,
                      double tolerance) {
  PlannedStep plan;
  plan.switching = state_after(now, stance_foot, switch_in, surface);
  plan.post_impact = {plan.switching.t, plan.switching.x,
                      plan.switching.xd + impact_velocity_change};
  plan.foot = reversal_foot(plan.post_impact, reversal_time, surface, reach, tolerance, velocity);
  plan.reversal = state_after(plan.post_impact, plan.foot, reversal_time, surface);
  return plan;
}

// pipm.py lateral_switch_time.
double lateral_switch_time(const PipmState& now, double stance_foot, double switch_in,
                           const LinearSurface& surface, double max_speed, double min_speed,
                           double shortest, double longest) {
  const double fast = time_to_speed(now, stance_foot, max_speed, surface);
  if (fast < switch_in) return std::max(shortest, fast);
  const PipmState switching = state_after(now, stance_foot, switch_in, surface);
  if (std::abs(switching.xd) < min_speed)
    return std::min(longest, switch_in + time_to_speed(switching, stance_foot, min_speed, surface));
  return switch_in;
}

}  // namespace lab
