"""Kim 2016 §V: the PIPM (eq. 24), its closed form on planar height surfaces, the
velocity-reversal footstep and the lateral timing rules (§V-2)."""

import math

import numpy as np
import pytest

from lab.controller.behaviours.pipm import (
    GRAVITY,
    LinearSurface,
    PipmState,
    lateral_switch_time,
    plan_step,
    predicted_path,
    reversal_foot,
    scaled_reversal_time,
    state_after,
    time_to_speed,
)

BOLT_HEIGHT = 0.3  # m, Bolt's CoM height
T_PRIME = 0.16  # s, biped_step's t′


def eq24(x: float, xd: float, foot: float, surface: LinearSurface) -> float:
    """ẍ of the PIPM, Kim's eq. 24, with h'' = 0 (a plane)."""
    return GRAVITY / (surface.at(x) - (x - foot) * surface.slope) * (x - foot)


def rk4(state: PipmState, foot: float, duration: float, surface: LinearSurface) -> PipmState:
    """Fig. 4c's numerical integration of eq. 24 (RK4, 0.1 ms steps): the oracle of the
    closed form."""
    steps = max(1, round(duration / 1e-4))
    dt, x, xd = duration / steps, state.x, state.xd
    for _ in range(steps):
        k1 = (xd, eq24(x, xd, foot, surface))
        k2 = (
            xd + 0.5 * dt * k1[1],
            eq24(x + 0.5 * dt * k1[0], xd + 0.5 * dt * k1[1], foot, surface),
        )
        k3 = (
            xd + 0.5 * dt * k2[1],
            eq24(x + 0.5 * dt * k2[0], xd + 0.5 * dt * k2[1], foot, surface),
        )
        k4 = (xd + dt * k3[1], eq24(x + dt * k3[0], xd + dt * k3[1], foot, surface))
        x += dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
        xd += dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
    return PipmState(state.t + duration, x, xd)


@pytest.mark.parametrize("slope", [0.0, 0.2, -0.3])
@pytest.mark.parametrize(("x", "xd", "foot"), [(0.02, 0.3, 0.0), (-0.05, 0.1, 0.04)])
def test_the_closed_form_is_eq_24_on_a_plane(
    slope: float, x: float, xd: float, foot: float
) -> None:
    """On a planar surface eq. 24 is linear with ω² = g / h(x_p): the closed form matches an
    RK4 integration of eq. 24 itself to 1e-9 m and m/s (RK4 at 0.1 ms errs ~1e-12 here)."""
    surface = LinearSurface(BOLT_HEIGHT, slope, origin=0.01)
    start = PipmState(0.5, x, xd)
    exact, numeric = state_after(start, foot, 0.3, surface), rk4(start, foot, 0.3, surface)
    assert exact.t == pytest.approx(0.8)
    assert exact.x == pytest.approx(numeric.x, abs=1e-9)
    assert exact.xd == pytest.approx(numeric.xd, abs=1e-9)


@pytest.mark.parametrize("slope", [0.0, 0.2, -0.3])
@pytest.mark.parametrize(("x", "xd"), [(0.02, 0.3), (-0.05, 0.1), (0.0, -0.4)])
def test_the_planned_step_reverses_the_velocity_at_t_prime(
    slope: float, x: float, xd: float
) -> None:
    """Integrating eq. 24 (RK4) from the post-impact state over the returned foot, the velocity
    is zero t′ after the switch within 1e-4 m/s (1 µm foot tolerance on slopes)."""
    surface = LinearSurface(BOLT_HEIGHT, slope)
    plan = plan_step(PipmState(0.0, x, xd), x - 0.03, 0.1, T_PRIME, surface, -0.01)
    assert plan.switching.t == pytest.approx(0.1)
    assert plan.post_impact.xd == pytest.approx(plan.switching.xd - 0.01)
    check = rk4(plan.post_impact, plan.foot, T_PRIME, surface)
    assert abs(check.xd) < 1e-4
    assert plan.reversal.t == pytest.approx(plan.post_impact.t + T_PRIME)
    assert plan.reversal.xd == pytest.approx(check.xd, abs=1e-9)


def test_a_steering_velocity_is_reached_at_t_prime() -> None:
    surface = LinearSurface(BOLT_HEIGHT)
    post = PipmState(0.0, 0.01, 0.25)
    foot = reversal_foot(post, T_PRIME, surface, velocity=0.2)
    assert state_after(post, foot, T_PRIME, surface).xd == pytest.approx(0.2, abs=1e-12)


def test_a_motion_no_step_within_reach_reverses_saturates_at_the_reach() -> None:
    fast = PipmState(0.0, 0.0, 5.0)
    for surface in (LinearSurface(BOLT_HEIGHT), LinearSurface(BOLT_HEIGHT, 0.1)):
        assert reversal_foot(fast, T_PRIME, surface, reach=0.2) == pytest.approx(0.2)


@pytest.mark.parametrize(
    ("x", "xd", "speed"), [(0.02, 0.0, 0.3), (0.02, -0.05, 0.1), (-0.03, 0.1, 0.2)]
)
def test_time_to_speed_is_the_first_time_the_speed_is_reached(
    x: float, xd: float, speed: float
) -> None:
    """Sampled at 0.1 ms, |ẋ| stays below the speed until the returned time and equals it there
    (1e-12 m/s), including a motion that first slows through zero (x 0.02, ẋ −0.05)."""
    surface, start = LinearSurface(BOLT_HEIGHT), PipmState(0.0, x, xd)
    t = time_to_speed(start, 0.0, speed, surface)
    assert 0.0 < t < 1.0
    assert abs(state_after(start, 0.0, t, surface).xd) == pytest.approx(speed, abs=1e-12)
    before = [abs(state_after(start, 0.0, s, surface).xd) for s in np.arange(0.0, t, 1e-4)]
    assert max(before) < speed


def test_time_to_speed_at_balance_is_never() -> None:
    """On the pendulum's stable manifold the CoM comes to rest over the foot: never faster
    (rounding leaves it on the manifold to ~1e-17 m/s, which takes seconds to grow)."""
    w = math.sqrt(GRAVITY / BOLT_HEIGHT)
    balanced = PipmState(0.0, -0.01, 0.01 * w)
    assert time_to_speed(balanced, 0.0, 0.1, LinearSurface(BOLT_HEIGHT)) > 3.0
    resting = PipmState(0.0, 0.0, 0.0)
    assert time_to_speed(resting, 0.0, 0.1, LinearSurface(BOLT_HEIGHT)) == math.inf


def test_the_switch_is_cut_where_the_sideways_speed_reaches_its_limit() -> None:
    surface, now = LinearSurface(BOLT_HEIGHT), PipmState(0.0, 0.03, 0.2)
    t = lateral_switch_time(now, 0.0, 0.2, surface, 0.36, 0.1, 0.05, 0.4)
    assert t < 0.2
    assert state_after(now, 0.0, t, surface).xd == pytest.approx(0.36, abs=1e-12)
    assert lateral_switch_time(now, 0.0, 0.2, surface, 0.36, 0.1, 0.15, 0.4) == 0.15


def test_a_slow_sideways_switch_is_lengthened_to_kims_0_1_m_s() -> None:
    """Kim §V-2: |ẏ| below 0.1 m/s at the default switch extends the step until it is 0.1,
    never beyond the longest swing."""
    surface, now = LinearSurface(BOLT_HEIGHT), PipmState(0.0, 0.006, 0.0)
    assert abs(state_after(now, 0.0, 0.1, surface).xd) < 0.1
    t = lateral_switch_time(now, 0.0, 0.1, surface, 0.36, 0.1, 0.05, 0.4)
    assert 0.1 < t < 0.4
    assert state_after(now, 0.0, t, surface).xd == pytest.approx(0.1, abs=1e-12)
    assert lateral_switch_time(now, 0.0, 0.1, surface, 0.36, 0.1, 0.05, 0.15) == 0.15
    fast_enough = PipmState(0.0, 0.04, 0.0)
    assert lateral_switch_time(fast_enough, 0.0, 0.1, surface, 0.36, 0.1, 0.05, 0.4) == 0.1


def test_the_predicted_path_runs_from_now_to_t_prime_after_the_switch() -> None:
    surface, now = LinearSurface(BOLT_HEIGHT), PipmState(1.0, 0.01, 0.1)
    path = predicted_path(now, 0.123, 0.05, T_PRIME, surface, origin=2.0)
    assert path[0] == pytest.approx([1.0, 2.01, 0.1])
    assert path[-1, 0] == pytest.approx(1.0 + 0.123 + T_PRIME)
    assert np.all(np.diff(path[:, 0]) <= 0.01 + 1e-12)


def test_hume_t_prime_scaled_to_bolt_is_0_13_s() -> None:
    """The value the lab departs from (docs/controller.md): 0.24 s √(0.3 / 1.0)."""
    assert scaled_reversal_time(BOLT_HEIGHT) == pytest.approx(0.131, abs=1e-3)
