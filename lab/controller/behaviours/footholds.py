"""Foothold planners: where a swinging foot should land, in world x, y, replanned every tick.

Both work in the horizontal frame H (the base frame turned about z by the base yaw only, origin
at the base), so the base's roll and pitch do not move the footholds (Raiola §3.2):

- `robocentric` (Raiola eqs. 19–25): the virtual foothold x_f⁰ (where the foot stands in the
  nominal posture) plus the displacement the commanded twist asks, ΔL = (v_d + ψ̇_d ẑ × x_hip) T,
  measured from the actual base, so errors do not accumulate and the legs stay near their
  preferred configuration. Eq. 19 takes T = 1 / f_sw; here T = T_st / 2, which centres the stance
  on the virtual foothold: under S3 (no velocity task: the posture pulls the base over the feet)
  the base then settles at the commanded velocity, with T = T_sw near 2 T_sw / T_st times it
  (docs/locomotion.md, "Step displacement").
- `raibert` (Hutter eq. 62): the hip's predicted position at touchdown, plus half the stance
  travel at the desired velocity (feed-forward), plus k_fb (v_hip − v_hip,d) sqrt(h / g)
  (feedback: a robot moving faster than asked, or pushed, steps further that way).

A foothold is a handful of scalar operations per leg, written out in x and y: as numpy 2-vectors
each operation would cost a numpy call's overhead, several times the arithmetic.
"""

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

GRAVITY = 9.81
RAIBERT_GAIN = 1.0  # k_fb of Hutter eq. 62

Planar = tuple[float, float] | np.ndarray  # x, y


@dataclass(slots=True)
class FootholdQuery:
    """What a planner needs for one swinging leg, every vector in H axes except `base_xy`.

    `hip` is the nominal foot position under the hip (the virtual foothold x_f⁰), relative to
    the base; `velocity` is the commanded base velocity [vx, vy] and `yaw_rate` the commanded
    turning rate; `hip_velocity` the measured velocity of the hip point; `height` the base height
    above the feet; `swing_left` the time until the planned touchdown; `stance_time` and
    `swing_time` the gait's durations.
    """

    base_xy: Planar
    yaw: float
    hip: Planar
    velocity: Planar
    yaw_rate: float
    hip_velocity: Planar
    height: float
    swing_left: float
    stance_time: float
    swing_time: float


def _to_world(query: FootholdQuery, x: float, y: float) -> np.ndarray:
    c, s = math.cos(query.yaw), math.sin(query.yaw)
    base_x, base_y = query.base_xy
    return np.array([base_x + c * x - s * y, base_y + s * x + c * y])


def _desired(query: FootholdQuery) -> tuple[float, float]:
    """The hip's commanded velocity v_d + ψ̇_d ẑ × x_hip."""
    (hip_x, hip_y), (vx, vy) = query.hip, query.velocity
    return vx - query.yaw_rate * hip_y, vy + query.yaw_rate * hip_x


def robocentric(query: FootholdQuery) -> np.ndarray:
    """Raiola eqs. 19–23: x_f⁰ + ΔL_xy0 + ΔL_h0, over half the stance time (see above)."""
    hip_x, hip_y = query.hip
    vx, vy = _desired(query)
    T = 0.5 * query.stance_time
    return _to_world(query, hip_x + T * vx, hip_y + T * vy)


def raibert(query: FootholdQuery) -> np.ndarray:
    """Hutter eq. 62 about the hip's position at touchdown."""
    hip_x, hip_y = query.hip
    vx, vy = _desired(query)
    hip_vx, hip_vy = query.hip_velocity
    # The hip at touchdown, + the feed-forward T_st / 2 v_d + the feedback k_fb (v_hip − v_d) √(h/g)
    ahead, half_stance = query.swing_left, 0.5 * query.stance_time
    gain = RAIBERT_GAIN * math.sqrt(query.height / GRAVITY)
    return _to_world(
        query,
        hip_x + ahead * vx + half_stance * vx + gain * (hip_vx - vx),
        hip_y + ahead * vy + half_stance * vy + gain * (hip_vy - vy),
    )


FOOTHOLD_PLANNERS: dict[str, Callable[[FootholdQuery], np.ndarray]] = {
    "robocentric": robocentric,
    "raibert": raibert,
}
