"""The constant-time-to-velocity-reversal footstep planner of Kim 2016 §V (eqs. 18–24), one
horizontal axis at a time (x and y separately, §V-2).

The prismatic inverted pendulum (PIPM): a point mass on a height surface z = h(x) over a point
foot at x_p, ẍ = (g + h''(x) ẋ²) / (h(x) − (x − x_p) h'(x)) · (x − x_p) (eq. 24). The planner
takes the CoM from its current state to the switching state (the stance foot changes), applies
the impact's velocity change (the post-impact state), and finds the next foot position so that
the CoM velocity reaches zero t′ after the switch (Fig. 4f–g).

The lab's height surfaces are planes, h(x) = h₀ + s (x − o): h'' = 0 and eq. 24's denominator
h(x) − (x − x_p) s = h(x_p) does not depend on x, so the PIPM is the linear inverted pendulum
ẍ = ω² (x − x_p) with ω² = g / h(x_p) (Kim: "if the height surface is planar, then this
relationship is linear"). Its closed form replaces Fig. 4c's numerical integration:
x(t) − x_p = (x₀ − x_p) cosh ωt + ẋ₀/ω sinh ωt. On a level plane the reversing foot is closed
form too; on a slope ω depends on the foot and Fig. 4f's bisection runs on the closed form.
"""

import math
from dataclasses import dataclass

import numpy as np

GRAVITY = 9.81


@dataclass(frozen=True)
class LinearSurface:
    """The CoM height surface h(x) = height + slope (x − origin) (a plane: h'' = 0)."""

    height: float
    slope: float = 0.0
    origin: float = 0.0

    def at(self, x: float) -> float:
        """h(x) (m)."""
        return self.height + self.slope * (x - self.origin)


@dataclass(frozen=True)
class PipmState:
    """Time (s), CoM position (m) and velocity (m/s) along one horizontal axis."""

    t: float
    x: float
    xd: float


def frequency(foot: float, surface: LinearSurface) -> float:
    """ω (1/s) of the PIPM over a foot at `foot`: eq. 24 on a plane is ẍ = g / h(x_p) (x − x_p)."""
    return math.sqrt(GRAVITY / surface.at(foot))


def state_after(
    state: PipmState, foot: float, duration: float, surface: LinearSurface
) -> PipmState:
    """The PIPM's state `duration` (s) after `state` over a foot at `foot` (the closed form)."""
    w = frequency(foot, surface)
    c, s = math.cosh(w * duration), math.sinh(w * duration)
    d = state.x - foot
    return PipmState(state.t + duration, foot + d * c + state.xd / w * s, d * w * s + state.xd * c)


def time_to_speed(state: PipmState, foot: float, speed: float, surface: LinearSurface) -> float:
    """The first time (s, from `state`) at which |ẋ| = `speed` (m/s) over a foot at `foot`, 0 if
    it is already at least that fast, ∞ if never. With u = e^{ωt}, ẋ = a u + b / u where
    a = (ẋ₀ + ω d) / 2 and b = (ẋ₀ − ω d) / 2 (d = x₀ − x_p): ẋ = ±speed is a u² ∓ speed u + b = 0,
    and the answer is its smallest root u ≥ 1."""
    if abs(state.xd) >= speed:
        return 0.0
    w = frequency(foot, surface)
    a = 0.5 * (state.xd + w * (state.x - foot))
    b = 0.5 * (state.xd - w * (state.x - foot))
    roots = []
    for v in (speed, -speed):
        if a == 0.0:
            roots.append(b / v)
            continue
        disc = v * v - 4.0 * a * b
        if disc >= 0.0:
            roots += [(v + sign * math.sqrt(disc)) / (2.0 * a) for sign in (1.0, -1.0)]
    u = min((r for r in roots if r >= 1.0), default=math.inf)
    return math.log(u) / w


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
    `velocity`, m/s: a steering bias) `reversal_time` after `post_impact`; saturates at the
    reach when no foot inside it reaches it. The velocity at t′ falls as the foot moves ahead
    (Fig. 4g). On a level surface it is linear in the foot: ẋ(t′) = (x − p) ω sinh ωt′ + ẋ cosh ωt′,
    so p = x + (ẋ cosh ωt′ − velocity) / (ω sinh ωt′); on a slope, bisection to `tolerance` (m)."""
    lo, hi = post_impact.x - reach, post_impact.x + reach
    if surface.slope == 0.0:
        w = frequency(0.0, surface)
        c, s = math.cosh(w * reversal_time), math.sinh(w * reversal_time)
        foot = post_impact.x + (post_impact.xd * c - velocity) / (w * s)
        return min(max(foot, lo), hi)

    def velocity_at_reversal(foot: float) -> float:
        return state_after(post_impact, foot, reversal_time, surface).xd - velocity

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
    impact's velocity change (Kim's bias, −0.1 m/s in x on Hume), and find the next foot
    that reverses the velocity `reversal_time` (t′) after the switch (or brings it to
    `velocity`, the steering bias), within `tolerance` (m) where it bisects."""
    switching = state_after(now, stance_foot, switch_in, surface)
    post = PipmState(switching.t, switching.x, switching.xd + impact_velocity_change)
    foot = reversal_foot(post, reversal_time, surface, reach, tolerance, velocity)
    reversal = state_after(post, foot, reversal_time, surface)
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
    a row about every `every` s, both ends included. The impact's velocity change is not
    applied."""
    rows: list[PipmState] = []
    start = now
    for duration, over in ((switch_in, 0.0), (reversal_time, foot)):
        n = max(1, math.ceil(duration / every - 1e-9))
        rows += [state_after(start, over, duration * k / n, surface) for k in range(n + 1)]
        start = rows[-1]
    return np.array([(s.t, s.x + origin, s.xd) for s in rows])


def lateral_switch_time(
    now: PipmState,
    stance_foot: float,
    switch_in: float,
    surface: LinearSurface,
    max_speed: float,
    min_speed: float,
    shortest: float,
    longest: float,
) -> float:
    """Kim §V-2's lateral timing rules: the time (s) from `now` to the switch. Shortened from
    `switch_in` to where the PIPM over the stance foot first reaches `max_speed` (m/s, |ẏ|),
    never below `shortest` (s); lengthened, when |ẏ| at `switch_in` is below `min_speed`, to
    where it first reaches `min_speed`, never beyond `longest` (s). The y phase plane runs
    before x so that x plans with it."""
    fast = time_to_speed(now, stance_foot, max_speed, surface)
    if fast < switch_in:
        return max(shortest, fast)
    switching = state_after(now, stance_foot, switch_in, surface)
    if abs(switching.xd) < min_speed:
        return min(longest, switch_in + time_to_speed(switching, stance_foot, min_speed, surface))
    return switch_in


def scaled_reversal_time(
    com_height: float, hume_time: float = 0.24, hume_height: float = 1.0
) -> float:
    """t′ scaled from Hume's 0.24 s (§V-2) by the pendulum time constant √(z/g); Hume's CoM
    height is not in the paper: 1.0 m (a 1.5 m robot) is assumed. Bolt (0.3 m): 0.13 s (the
    lab's Bolt uses 0.16 s: `biped_step.SteppingTimes.reversal_time` says why)."""
    return hume_time * float(np.sqrt(com_height / hume_height))
