"""Swing trajectory: the half ellipse of Raiola eqs. 26–29, and its reaching continuation.

In the swing frame S (origin at the lift-off point, x along the step heading ψ_s, z up; blind,
so the terrain is taken as level) the foot follows, for t in [0, T_sw] with f_sw = 1 / T_sw,

    x = L_s / 2 (1 − cos(π f_sw t)),   y = 0,   z = H_s sin(π f_sw t),

and is mapped to the world by the rotation ψ_s about z (eq. 27). L_s and ψ_s come from the
foothold, replanned every tick. Past T_sw without a touchdown the foot keeps descending at its
touchdown speed (reaching motion, §3.3) until the ground is felt.

The ellipse is walked with the time t' = T_sw (6u³ − 8u⁴ + 3u⁵), u = t / T_sw, instead of t: the
same path and the same touchdown velocity (t' and dt'/dt are 0 and 1 at the ends, d²t'/dt² = 0
at both), but the foot leaves the ground at rest, without a step in velocity or acceleration.
With t itself the reference would jump to the lift-off velocity H_s π f_sw (about 1 m/s) and the
swing task would jerk the stance legs (measured: docs/locomotion.md).
"""

import math

import numpy as np


def swing_reference(
    start: np.ndarray, target_xy: np.ndarray, height: float, t: float, duration: float
) -> np.ndarray:
    """Position, velocity and acceleration (world, the rows of a 3 × 3 array) at time t after
    lift-off from `start`."""
    x0, y0, z0 = start.tolist()
    x1, y1 = target_xy.tolist()
    step_x, step_y = x1 - x0, y1 - y0
    length = math.hypot(step_x, step_y)
    hx, hy = (step_x / length, step_y / length) if length > 1e-9 else (0.0, 0.0)  # heading ψ_s
    w = math.pi / duration
    if t <= duration:
        u = t / duration
        warped = duration * u**3 * (6.0 - 8.0 * u + 3.0 * u**2)  # t'
        rate = u**2 * (18.0 - 32.0 * u + 15.0 * u**2)  # dt'/dt
        rate_dot = u * (36.0 - 96.0 * u + 60.0 * u**2) / duration  # d²t'/dt²
        s, c = math.sin(w * warped), math.cos(w * warped)
        x, dx, ddx = 0.5 * length * (1.0 - c), 0.5 * length * w * s, 0.5 * length * w * w * c
        z, dz, ddz = height * s, height * w * c, -height * w * w * s
        ddx, ddz = ddx * rate**2 + dx * rate_dot, ddz * rate**2 + dz * rate_dot
        dx, dz = dx * rate, dz * rate
    else:
        x, dx, ddx = length, 0.0, 0.0
        z, dz, ddz = -height * w * (t - duration), -height * w, 0.0
    return np.array(
        [
            [x0 + x * hx, y0 + x * hy, z0 + z],  # position
            [dx * hx, dx * hy, dz],  # velocity
            [ddx * hx, ddx * hy, ddz],  # acceleration
        ]
    )
