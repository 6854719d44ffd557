"""Tracking metrics. `cog_tracking`: how closely the CoG follows the behaviour's reference (Herzog
2016 §5.3's squat): the largest and the RMS |c − c_ref| (m), overall and along z, over the run.
`swing_tracking`: how closely a swinging leg follows its joint trajectory (Herzog §5.4, Fig. 11):
the largest and the RMS |q_ref − q| over its joints (rad), over the ticks it swings."""

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from lab.world.session import Session


class CogTrackingMetrics:
    def __init__(self, session: "Session") -> None:
        self.errors: list[np.ndarray] = []

    def update(self, session: "Session") -> None:
        self.errors.append(session.model.com - session.controller.references.com)

    def result(self) -> dict[str, float]:
        e = np.array(self.errors) if self.errors else np.zeros((1, 3))
        norm = np.linalg.norm(e, axis=1)
        return {
            "cog_error_max_m": float(norm.max()),
            "cog_error_rms_m": float(np.sqrt(np.mean(norm**2))),
            "cog_error_z_max_m": float(np.abs(e[:, 2]).max()),
            "cog_error_z_rms_m": float(np.sqrt(np.mean(e[:, 2] ** 2))),
        }


class SwingTrackingMetrics:
    def __init__(self, session: "Session") -> None:
        self.errors: list[float] = []

    def update(self, session: "Session") -> None:
        error = session.controller.task_errors().get("swing_leg", 0.0)
        if error > 0.0:
            self.errors.append(error)

    def result(self) -> dict[str, float]:
        e = np.array(self.errors) if self.errors else np.zeros(1)
        return {
            "swing_error_max_rad": float(e.max()),
            "swing_error_rms_rad": float(np.sqrt(np.mean(e**2))),
            "swing_ticks": float(len(self.errors)),
        }
