"""Squat: the CoG tracks sine curves in double support (Herzog 2016 §5.3).

After HOLD s the CoG reference moves as c(t) = c₀ + [A_x, 0, A_z] sin(2π t / period) with the
paper's amplitudes (2 cm forward, 3 cm vertical) and its velocity as the momentum reference;
the period is the gait option `cycle_time` (the paper ran 0.3 and 0.5 Hz: 3.33 s and 2 s).
"""

import numpy as np

from lab.controller.behaviours.balance import Balance
from lab.controller.model import RobotModel

HOLD = 0.5  # s
AMPLITUDE = np.array([0.02, 0.0, 0.03])  # m: forward, sideways, vertical
PERIOD = 2.0  # s: 0.5 Hz
PERIOD_RANGE = (1.0, 5.0)  # s (the protocol allows cycle_time up to 5 s)


class Squat(Balance):
    """Stand on every foot with the CoG reference on a sine (module docstring)."""

    name = "squat"

    def __init__(self, robot: RobotModel, q_standing: np.ndarray) -> None:
        super().__init__(robot, q_standing)
        self.centre = self.references.com.copy()
        self.period = PERIOD
        self.start: float | None = None

    def configure(self, **options: object) -> None:
        """`cycle_time`: the sine's period (s) in PERIOD_RANGE; raises ValueError otherwise."""
        unknown = set(options) - {"cycle_time"}
        if unknown:
            raise ValueError(f"gait 'squat' takes no {', '.join(sorted(unknown))}")
        period = options.get("cycle_time", self.period)
        if not isinstance(period, int | float) or not PERIOD_RANGE[0] <= period <= PERIOD_RANGE[1]:
            raise ValueError(f"squat: cycle_time must be in {PERIOD_RANGE} s, got {period!r}")
        self.period = float(period)

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Hold for HOLD s from the first tick, then move the CoG reference on the sine."""
        self.start = t if self.start is None else self.start
        phase = max(t - self.start - HOLD, 0.0)
        omega = 2.0 * np.pi / self.period
        active = t - self.start >= HOLD
        self.references.com = self.centre + AMPLITUDE * np.sin(omega * phase)
        self.references.com_velocity = AMPLITUDE * omega * np.cos(omega * phase) * active
