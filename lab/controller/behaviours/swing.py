"""Swing trajectory: the half ellipse of Raiola eqs. 26–29, and its reaching continuation.

In the swing frame S (origin at the lift-off point, x along the step heading ψ_s, z up; blind,
so the terrain is taken as level) the foot follows, for t in [0, T_sw] with f_sw = 1 / T_sw,

    x = L_s / 2 (1 − cos(π f_sw t)),   y = 0,   z = H_s sin(π f_sw t),

and is mapped to the world by the rotation ψ_s about z (eq. 27). L_s and ψ_s come from the
foothold, replanned every tick. Past T_sw without a touchdown the foot keeps descending at its
touchdown speed (reaching motion, §3.3) until the ground is felt.
"""

import numpy as np


def swing_reference(
    start: np.ndarray, target_xy: np.ndarray, height: float, t: float, duration: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration (world) at time t after lift-off from `start`."""
    step = target_xy - start[:2]
    length = float(np.hypot(*step))
    heading = step / length if length > 1e-9 else np.zeros(2)
    w = np.pi / duration
    if t <= duration:
        s, c = np.sin(w * t), np.cos(w * t)
        x, dx, ddx = 0.5 * length * (1.0 - c), 0.5 * length * w * s, 0.5 * length * w * w * c
        z, dz, ddz = height * s, height * w * c, -height * w * w * s
    else:
        x, dx, ddx = length, 0.0, 0.0
        z, dz, ddz = -height * w * (t - duration), -height * w, 0.0
    position = np.array([*(start[:2] + x * heading), start[2] + z])
    velocity = np.array([*(dx * heading), dz])
    acceleration = np.array([*(ddx * heading), ddz])
    return position, velocity, acceleration
