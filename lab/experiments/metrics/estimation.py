"""State-estimation metrics: what the controller read of the base against the truth (issue 30
item 1's targets: base height error < 2 cm, yaw drift < 5°/min), from telemetry's `estimator`
report (lab/world/estimator.py), which is zero on ticks whose controller read the true state.
"""

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from lab.world.session import Session


class EstimationMetrics:
    """Largest base height and horizontal position errors, the yaw drift (the last yaw error
    over the run's minutes) and the largest yaw error, the RMS base velocity error."""

    def __init__(self, session: "Session") -> None:
        self.height = self.horizontal = self.yaw = self.last_yaw = 0.0
        self.velocity_squares = 0.0
        self.samples = 0
        self.time = 0.0

    def update(self, session: "Session") -> None:
        native = session.tick_report()["tick"] == "native"
        report = session.estimator.report(exact=native and not session.estimator.active)
        position = report["position_error"]
        self.height = max(self.height, abs(position[2]))
        self.horizontal = max(self.horizontal, math.hypot(position[0], position[1]))
        self.last_yaw = report["yaw_error"]
        self.yaw = max(self.yaw, abs(self.last_yaw))
        self.velocity_squares += float(np.dot(report["velocity_error"], report["velocity_error"]))
        self.samples += 1
        self.time = session.time

    def result(self) -> dict[str, float]:
        minutes = self.time / 60.0
        return {
            "max_estimate_height_error_m": self.height,
            "max_estimate_horizontal_error_m": self.horizontal,
            "max_estimate_yaw_error_deg": math.degrees(self.yaw),
            "yaw_drift_deg_per_min": (
                math.degrees(abs(self.last_yaw)) / minutes if minutes > 0 else 0.0
            ),
            "rms_estimate_velocity_error_mps": (
                math.sqrt(self.velocity_squares / self.samples) if self.samples else 0.0
            ),
        }
