"""The constant-time-to-velocity-reversal footstep planner of Kim 2016 §V (eqs. 18–24), one
horizontal axis at a time (x and y separately, §V-2).

The prismatic inverted pendulum (PIPM): a point mass on a height surface z = h(x) over a point
foot at x_p, ẍ = (g + h''(x) ẋ²) / (h(x) − (x − x_p) h'(x)) · (x − x_p) (eq. 24). The planner
integrates it from the current CoM state to the switching state (the stance foot changes),
applies the impact's velocity change (the post-impact state), and bisects on the next foot
position so that the CoM velocity reaches zero t′ after the switch (Fig. 4f–g: the velocity at
t′ falls monotonically as the foot moves ahead).
"""

from dataclasses import dataclass

import numpy as np

GRAVITY = 9.81
STEP_DT = 1e-3  # s, the integration step (RK4)


@dataclass(frozen=True)
class LinearSurface:
    """The CoM height surface h(x) = height + slope (x − origin) (a plane: h'' = 0)."""

    height: float
    slope: float = 0.0
    origin: float = 0.0

    def at(self, x: float) -> tuple[float, float, float]:
        """h(x), h'(x), h''(x)."""
        return self.height + self.slope * (x - self.origin), self.slope, 0.0


@dataclass(frozen=True)
class PipmState:
    """Time (s), CoM position (m) and velocity (m/s) along one horizontal axis."""

    t: float
    x: float
    xd: float


def acceleration(x: float, xd: float, foot: float, surface: LinearSurface) -> float:
    """ẍ of the PIPM (eq. 24) over a point foot at `foot`."""
    h, dh, ddh = surface.at(x)
    return (GRAVITY + ddh * xd * xd) / (h - (x - foot) * dh) * (x - foot)


def integrate(state: PipmState, foot: float, duration: float, surface: LinearSurface) -> list:
    """The PIPM's states from `state` over `duration` (s) with the foot at `foot` (RK4)."""
    steps = max(1, round(duration / STEP_DT))
    dt = duration / steps
    x, xd, t = state.x, state.xd, state.t
    out = [state]
    for _ in range(steps):
        k1 = (xd, acceleration(x, xd, foot, surface))
        k2 = (
            xd + 0.5 * dt * k1[1],
            acceleration(x + 0.5 * dt * k1[0], xd + 0.5 * dt * k1[1], foot, surface),
        )
        k3 = (
            xd + 0.5 * dt * k2[1],
            acceleration(x + 0.5 * dt * k2[0], xd + 0.5 * dt * k2[1], foot, surface),
        )
        k4 = (xd + dt * k3[1], acceleration(x + dt * k3[0], xd + dt * k3[1], foot, surface))
        x += dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
        xd += dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
        t += dt
        out.append(PipmState(t, x, xd))
    return out


@dataclass(frozen=True)
class PlannedStep:
    """The planner's answer: the next foot position (m) and the states it predicted on the way
    (Fig. 4: switching ◇, post-impact ◆, reversal ★)."""

    foot: float
    switching: PipmState
    post_impact: PipmState
    reversal: PipmState


def reversal_foot(
    post_impact: PipmState,
    reversal_time: float,
    surface: LinearSurface,
    reach: float = 0.5,
    tolerance: float = 1e-6,
    velocity: float = 0.0,
) -> float:
    """The foot position within `reach` (m) of the CoM whose PIPM velocity is zero (or
    `velocity`, m/s: a steering bias) `reversal_time` after `post_impact`, by bisection (the
    velocity falls as the foot moves ahead); saturates at the reach when no foot inside it
    reaches it."""

    def velocity_at_reversal(foot: float) -> float:
        return integrate(post_impact, foot, reversal_time, surface)[-1].xd - velocity

    lo, hi = post_impact.x - reach, post_impact.x + reach
    if velocity_at_reversal(lo) <= 0.0:
        return lo
    if velocity_at_reversal(hi) >= 0.0:
        return hi
    while hi - lo > tolerance:
        middle = 0.5 * (lo + hi)
        if velocity_at_reversal(middle) > 0.0:
            lo = middle
        else:
            hi = middle
    return 0.5 * (lo + hi)


def plan_step(
    now: PipmState,
    stance_foot: float,
    switch_in: float,
    reversal_time: float,
    surface: LinearSurface,
    impact_velocity_change: float = 0.0,
    reach: float = 0.5,
    velocity: float = 0.0,
    tolerance: float = 1e-6,
) -> PlannedStep:
    """Predict the switching state `switch_in` s from `now` over the stance foot, add the
    impact's velocity change (Kim's bias, −0.01 m/s in x in simulation), and find the next foot
    that reverses the velocity `reversal_time` (t′) after the switch (or brings it to
    `velocity`, the steering bias), within `tolerance` (m)."""
    switching = integrate(now, stance_foot, switch_in, surface)[-1]
    post = PipmState(switching.t, switching.x, switching.xd + impact_velocity_change)
    foot = reversal_foot(post, reversal_time, surface, reach, tolerance, velocity)
    reversal = integrate(post, foot, reversal_time, surface)[-1]
    return PlannedStep(foot, switching, post, reversal)


def predicted_path(
    now: PipmState,
    switch_in: float,
    foot: float,
    reversal_time: float,
    surface: LinearSurface,
    origin: float = 0.0,
    every: float = 0.01,
) -> np.ndarray:
    """The PIPM's path (rows t, x, ẋ; x shifted by `origin`, m) over a stance foot at 0 for
    `switch_in` s from `now`, then over `foot` for `reversal_time` s (Fig. 4: ● → ◇, ◆ → ★),
    a row every `every` s. The impact's velocity change is not applied."""
    before = integrate(now, 0.0, switch_in, surface)
    after = integrate(before[-1], foot, reversal_time, surface)
    stride = max(1, round(every / STEP_DT))
    states = before[::stride] + after[::stride]
    return np.array([(s.t, s.x + origin, s.xd) for s in states])


def capped_switch_time(
    now: PipmState,
    stance_foot: float,
    switch_in: float,
    surface: LinearSurface,
    max_speed: float,
    shortest: float,
) -> float:
    """Kim §V-2's lateral timing rule: the time (s) from `now` to the switch, shortened from
    `switch_in` to where the PIPM over the stance foot first reaches `max_speed` (m/s, |ẋ|),
    never below `shortest` (s). The y phase plane runs before x so that x plans with it."""
    for state in integrate(now, stance_foot, switch_in, surface):
        if abs(state.xd) >= max_speed:
            return min(switch_in, max(shortest, state.t - now.t))
    return switch_in


def scaled_reversal_time(
    com_height: float, hume_time: float = 0.24, hume_height: float = 1.0
) -> float:
    """t′ scaled from Hume's 0.24 s (§V-2) by the pendulum time constant √(z/g); Hume's CoM
    height is not in the paper: 1.0 m (a 1.5 m robot) is assumed. Bolt (0.3 m): 0.13 s."""
    return hume_time * float(np.sqrt(com_height / hume_height))
