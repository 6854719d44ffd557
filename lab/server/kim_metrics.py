"""Metrics of the Kim 2016 replications (see metrics.py): the internal force between two point
feet, measured (MuJoCo's contact forces, as a foot force sensor gives them) against its
reference, and the largest foot slide.

- `internal_force`: mean, RMS and largest |error| of the measured F_int = W_int λ (eqs. 14–17)
  against the task's reference, over the ticks from SETTLE on with both feet in support; the
  largest horizontal slide of a foot from where it stood at SETTLE.
"""

from typing import TYPE_CHECKING

import numpy as np

from lab.controller.internal_force import internal_forces

if TYPE_CHECKING:
    from lab.server.session import Session

SETTLE = 0.5  # s: the first half second (the force builds up from zero) is not scored


class InternalForceMetrics:
    def __init__(self, session: "Session") -> None:
        self.errors: list[float] = []
        self.start: np.ndarray | None = None
        self.slide = 0.0

    def update(self, session: "Session") -> None:
        if session.time < SETTLE or session.fell:
            return
        model = session.model
        if self.start is None:
            self.start = model.contact_positions[:, :2].copy()
        slide = np.linalg.norm(model.contact_positions[:, :2] - self.start, axis=1)
        self.slide = max(self.slide, float(slide.max()))
        if not np.all(session.controller.references.contact_active):
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


KIM_METRICS: dict[str, type] = {"internal_force": InternalForceMetrics}
