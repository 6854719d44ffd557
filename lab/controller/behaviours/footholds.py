"""Foothold planners: where a swinging foot should land, in world x, y, replanned every tick.

Both work in the horizontal frame H (the base frame turned about z by the base yaw only, origin
at the base), so the base's roll and pitch do not move the footholds (Raiola §3.2):

- `robocentric` (Raiola eqs. 19–25): the virtual foothold x_f⁰ (where the foot stands in the
  nominal posture) plus the displacement the commanded twist asks, ΔL = (v_d + ψ̇_d ẑ × x_hip) T,
  measured from the actual base, so errors do not accumulate and the legs stay near their
  preferred configuration. Eq. 19 takes T = 1 / f_sw; here T = T_st / 2, which centres the stance
  on the virtual foothold. Under S3 (no velocity task: the posture pulls the base over the feet)
  the base then settles at the commanded velocity; with T = T_sw (0.27 s for ANYmal's trot
  against T_st / 2 = 0.17 s) it settled near 2 T_sw / T_st = 1.6 times the command and ANYmal's
  0.5 m/s trot ran away to 1.9 m/s and fell after 7 s.
- `raibert` (Hutter eq. 62): the hip's predicted position at touchdown, plus half the stance
  travel at the desired velocity (feed-forward), plus k_fb (v_hip − v_hip,d) sqrt(h / g)
  (feedback: a robot moving faster than asked, or pushed, steps further that way).

A query holds one leg (2-vectors, a scalar `swing_left`) or every leg at once (one row per leg):
the planners broadcast over the rows.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

GRAVITY = 9.81
RAIBERT_GAIN = 1.0  # k_fb of Hutter eq. 62
QUARTER_TURN = np.array([[0.0, 1.0], [-1.0, 0.0]])  # row vectors: p @ QUARTER_TURN = ẑ × p


@dataclass(frozen=True)
class FootholdQuery:
    """What a planner needs for the swinging legs, every vector in H axes except `base_xy`.

    `hip` is the nominal foot position under the hip (the virtual foothold x_f⁰), relative to
    the base; `velocity` is the commanded base velocity [vx, vy] and `yaw_rate` the commanded
    turning rate; `hip_velocity` the measured velocity of the hip point; `height` the base height
    above the feet; `swing_left` the time until the planned touchdown; `stance_time` and
    `swing_time` the gait's durations. `hip`, `hip_velocity` and `swing_left` have a row per leg
    (or are one leg's).
    """

    base_xy: np.ndarray
    yaw: float
    hip: np.ndarray
    velocity: np.ndarray
    yaw_rate: float
    hip_velocity: np.ndarray
    height: float
    swing_left: float | np.ndarray
    stance_time: float
    swing_time: float


def _to_world(query: FootholdQuery, xy_h: np.ndarray) -> np.ndarray:
    c, s = math.cos(query.yaw), math.sin(query.yaw)
    return query.base_xy + xy_h @ np.array([[c, s], [-s, c]])  # rows turned by the yaw


def robocentric(query: FootholdQuery) -> np.ndarray:
    """Raiola eqs. 19–23: x_f⁰ + ΔL_xy0 + ΔL_h0, over half the stance time (see above)."""
    turn = query.yaw_rate * (query.hip @ QUARTER_TURN)  # ψ̇ ẑ × x_hip
    step = 0.5 * query.stance_time * (query.velocity + turn)
    return _to_world(query, query.hip + step)


def raibert(query: FootholdQuery) -> np.ndarray:
    """Hutter eq. 62 about the hip's position at touchdown."""
    desired = query.velocity + query.yaw_rate * (query.hip @ QUARTER_TURN)
    swing_left = np.asarray(query.swing_left)[..., None]
    hip_at_touchdown = query.hip + swing_left * desired
    feedforward = 0.5 * query.stance_time * desired
    feedback = RAIBERT_GAIN * (query.hip_velocity - desired) * math.sqrt(query.height / GRAVITY)
    return _to_world(query, hip_at_touchdown + feedforward + feedback)


FOOTHOLD_PLANNERS: dict[str, Callable[[FootholdQuery], np.ndarray]] = {
    "robocentric": robocentric,
    "raibert": raibert,
}
