"""Metrics of the Kim 2016 replications (see metrics.py): the internal force between two point
feet, measured (MuJoCo's contact forces, as a foot force sensor gives them) against its
reference, and the largest foot slide.

- `internal_force`: mean, RMS and largest |error| of the measured F_int = W_int λ (eqs. 14–17)
  against the task's reference, over the ticks from SETTLE on with both feet in support; the
  largest horizontal slide of a foot from where it stood at SETTLE.
- `stepping`: the steps of a stepping behaviour (touchdowns) and how long it stepped; the
  largest errors of the CoM height, of the base height and of the body's roll-pitch against
  their references while stepping (Kim Fig. 8d: 2 cm, 0.15 rad); how far the CoM wandered
  horizontally from where stepping began, and where it ended (world x, y from there); the
  CoM's path length and the base's unwrapped yaw turned; how many swings the lateral planner
  cut short or lengthened (`biped_step`). Per tick on Python floats (math, not numpy calls on
  2- and 3-vectors: 31 µs a tick with them, a third of a native tick).
"""

import math
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from lab.controller.internal_force import internal_forces

if TYPE_CHECKING:
    from lab.world.session import Session

SETTLE = 0.5  # s: the first half second (the force builds up from zero) is not scored


class InternalForceMetrics:
    def __init__(self, session: "Session") -> None:
        self.errors: list[float] = []
        self.start: list[list[float]] | None = None  # each foot's (x, y) at SETTLE
        self.slide = 0.0

    def update(self, session: "Session") -> None:
        if session.time < SETTLE or session.fell:
            return
        model = session.model
        # Python floats: with numpy calls on the feet's 2-vectors the metric cost a third of a
        # native tick (benchmarks/bench_scenarios.py)
        feet = model.contact_positions[:, :2].tolist()
        if self.start is None:
            self.start = feet
        for (x, y), (x0, y0) in zip(feet, self.start, strict=True):
            self.slide = max(self.slide, math.sqrt((x - x0) ** 2 + (y - y0) ** 2))
        if not all(session.controller.references.contact_active.tolist()):
            return
        measured = internal_forces(model.contact_positions, session.plant.foot_forces())
        self.errors.append(float(measured[0]) - session.controller.internal_force.reference)

    def result(self) -> dict[str, float]:
        e = np.array(self.errors) if self.errors else np.full(1, np.nan)
        return {
            "internal_force_mean_error_n": float(np.mean(e)),
            "internal_force_rms_error_n": float(np.sqrt(np.mean(e * e))),
            "internal_force_max_error_n": float(np.max(np.abs(e))),
            "max_foot_slide_m": self.slide,
        }


class SteppingMetrics:
    def __init__(self, session: "Session") -> None:
        self.start: float | None = None
        self.origin = (0.0, 0.0)  # the CoM (x, y) where stepping began
        self.steps = self.cut = self.lengthened = 0
        self.duration = 0.0
        self.com_height = self.base_height = self.orientation = self.wander = 0.0
        self.travel = (0.0, 0.0)  # the CoM (x, y) from there
        self.path = self.turned = 0.0  # m walked by the CoM, rad turned by the base (unwrapped)
        # the CoM's (x, y) and the base's yaw at the last tick
        self.last: tuple[tuple[float, float], float] | None = None

    def update(self, session: "Session") -> None:
        stepping = session.behaviour.stepping
        if stepping is None or session.fell:
            return
        model, refs = session.model, session.controller.references
        com = model.com
        if self.start is None:
            self.start, self.origin = session.time, (float(com[0]), float(com[1]))
        self.steps, self.duration = stepping.steps, session.time - self.start
        self.cut, self.lengthened = stepping.shortened, stepping.lengthened
        self.com_height = max(self.com_height, abs(float(refs.com[2]) - float(com[2])))
        base_height = float(model.base_position[2])
        self.base_height = max(self.base_height, abs(refs.base_height - base_height))
        tilt = pin.log3(refs.base_rotation.T @ model.base_rotation)
        yaw_axis = refs.base_rotation[:, 2]
        roll_pitch = tilt - (tilt @ yaw_axis) * yaw_axis  # yaw is not a task while stepping
        self.orientation = max(self.orientation, math.sqrt(roll_pitch @ roll_pitch))
        x, y = float(com[0]), float(com[1])
        self.travel = (x - self.origin[0], y - self.origin[1])
        rotation = model.base_rotation
        yaw = math.atan2(rotation[1, 0], rotation[0, 0])
        if self.last is not None:
            (last_x, last_y), last_yaw = self.last
            self.path += math.sqrt((x - last_x) ** 2 + (y - last_y) ** 2)
            turn = yaw - last_yaw  # wrapped into (−π, π] as np.angle(np.exp(1j * turn)) does
            self.turned += math.atan2(math.sin(turn), math.cos(turn))
        self.last = (x, y), yaw
        self.wander = max(self.wander, math.sqrt(self.travel[0] ** 2 + self.travel[1] ** 2))

    def result(self) -> dict[str, float]:
        return {
            "steps": float(self.steps),
            "stepping_s": self.duration,
            "swings_cut": float(self.cut),
            "swings_lengthened": float(self.lengthened),
            "max_com_height_error_m": self.com_height,
            "max_base_height_error_m": self.base_height,
            "max_roll_pitch_error_rad": self.orientation,
            "max_com_wander_m": self.wander,
            "com_travel_x_m": float(self.travel[0]),
            "com_travel_y_m": float(self.travel[1]),
            "com_path_m": self.path,
            "yaw_turned_rad": self.turned,
        }


KIM_METRICS: dict[str, type] = {
    "internal_force": InternalForceMetrics,
    "stepping": SteppingMetrics,
}
