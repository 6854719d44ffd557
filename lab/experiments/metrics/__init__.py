"""Scenario metrics: accumulators fed once per tick, each reporting a few named numbers.

Every scenario reports the `standing` metrics; a scenario file lists more by name in
`metrics = [...]`. A metric is a class with `update(session)` (after each tick) and
`result() -> dict[str, float]`; register it in METRICS.
"""

import math
from typing import TYPE_CHECKING, Protocol

import pinocchio as pin

from lab.experiments.metrics.cop import CopBindingMetrics
from lab.experiments.metrics.estimation import EstimationMetrics
from lab.experiments.metrics.hand import HandTrackingMetrics
from lab.experiments.metrics.kim import KIM_METRICS
from lab.experiments.metrics.load import LOAD_METRICS
from lab.experiments.metrics.locomotion import LocomotionMetrics
from lab.experiments.metrics.push import PushMetrics
from lab.experiments.metrics.scene import SceneMotionMetrics
from lab.experiments.metrics.sole_cop import SoleCopMetrics
from lab.experiments.metrics.tracking import CogTrackingMetrics, SwingTrackingMetrics

if TYPE_CHECKING:
    from lab.world.session import Session


class Metric(Protocol):
    def update(self, session: "Session") -> None: ...

    def result(self) -> dict[str, float]: ...


class StandingMetrics:
    """Largest base-orientation and base-height errors, peak measured normal force. Every
    scenario runs it every tick: Python floats, no numpy call on a small vector (12-15 µs a tick
    with them, a tenth of a native tick)."""

    def __init__(self, session: "Session") -> None:
        self.reference_height = session.controller.references.base_height
        self.orientation = self.height = self.peak_normal = 0.0

    def update(self, session: "Session") -> None:
        # Session.base_orientation_error, its norm as np.linalg.norm computes it
        rotation = session.controller.references.base_rotation.T @ session.model.base_rotation
        error = pin.log3(rotation)
        self.orientation = max(self.orientation, math.sqrt(error @ error))
        self.height = max(self.height, abs(float(session.model.q[2]) - self.reference_height))
        self.peak_normal = max(self.peak_normal, max(session.plant.foot_forces()[:, 2].tolist()))

    def result(self) -> dict[str, float]:
        return {
            "max_base_orientation_error_rad": self.orientation,
            "max_base_height_error_m": self.height,
            "peak_contact_normal_force_n": self.peak_normal,
        }


METRICS: dict[str, type] = {
    "standing": StandingMetrics,
    "locomotion": LocomotionMetrics,
    "pushes": PushMetrics,
    "cog_tracking": CogTrackingMetrics,
    "swing_tracking": SwingTrackingMetrics,
    "hand_tracking": HandTrackingMetrics,
    "cop_binding": CopBindingMetrics,
    "sole_cop": SoleCopMetrics,
    "scene_motion": SceneMotionMetrics,
    "estimation": EstimationMetrics,
    **LOAD_METRICS,
    **KIM_METRICS,
}
