"""Kim 2016 §V: the PIPM (eq. 24) and the velocity-reversal footstep bisection."""

import numpy as np
import pytest

from lab.controller.behaviours.pipm import (
    GRAVITY,
    LinearSurface,
    PipmState,
    integrate,
    plan_step,
    reversal_foot,
    scaled_reversal_time,
)

BOLT_HEIGHT = 0.3  # m, Bolt's CoM height


def test_on_a_level_surface_the_pipm_is_the_linear_inverted_pendulum() -> None:
    """ẍ = g/z (x − x_p): x − x_p = a cosh(ωt) + (ẋ₀/ω) sinh(ωt)."""
    surface = LinearSurface(BOLT_HEIGHT)
    w = np.sqrt(GRAVITY / BOLT_HEIGHT)
    end = integrate(PipmState(0.0, 0.03, -0.2), 0.0, 0.3, surface)[-1]
    assert end.x == pytest.approx(0.03 * np.cosh(0.3 * w) - 0.2 / w * np.sinh(0.3 * w), abs=1e-9)


@pytest.mark.parametrize("slope", [0.0, 0.2, -0.3])
@pytest.mark.parametrize(("x", "xd"), [(0.02, 0.3), (-0.05, 0.1), (0.0, -0.4)])
def test_the_bisection_returns_a_step_whose_velocity_reverses_at_t_prime(
    slope: float, x: float, xd: float
) -> None:
    """Integrating the PIPM from the post-impact state over the returned foot, the velocity is
    zero t′ after the switch within 1e-4 m/s (1 µm foot tolerance)."""
    surface = LinearSurface(BOLT_HEIGHT, slope)
    t_prime = scaled_reversal_time(BOLT_HEIGHT)
    plan = plan_step(PipmState(0.0, x, xd), x - 0.03, 0.1, t_prime, surface, -0.01)
    assert plan.switching.t == pytest.approx(0.1)
    assert plan.post_impact.xd == pytest.approx(plan.switching.xd - 0.01)
    check = integrate(plan.post_impact, plan.foot, t_prime, surface)[-1]
    assert abs(check.xd) < 1e-4
    assert check.t == pytest.approx(plan.post_impact.t + t_prime)
    # On a level surface the answer is closed form: p = x + ẋ coth(ω t′)/ω.
    if slope == 0.0:
        w = np.sqrt(GRAVITY / BOLT_HEIGHT)
        post = plan.post_impact
        assert plan.foot == pytest.approx(post.x + post.xd / (w * np.tanh(w * t_prime)), abs=1e-5)


def test_a_motion_no_step_within_reach_reverses_saturates_at_the_reach() -> None:
    surface = LinearSurface(BOLT_HEIGHT)
    fast = PipmState(0.0, 0.0, 5.0)
    assert reversal_foot(fast, 0.13, surface, reach=0.2) == pytest.approx(0.2)
