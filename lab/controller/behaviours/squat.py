"""Squat: the CoG tracks sine curves in double support (Herzog 2016 §5.3).

After HOLD s the CoG reference moves as c(t) = c₀ + [A_x, 0, A_z] sin(2π t / period) with the
paper's amplitudes (2 cm forward, 3 cm vertical), its velocity as the momentum reference and
its acceleration as the momentum rate fed forward;
the period is the gait option `cycle_time` (the paper ran 0.3 and 0.5 Hz: 3.33 s and 2 s).

`squat_cop` is the variant of Fig. 10 whose CoP constraints bind: 4.5 cm forward instead of 2.
At 0.5 Hz the CoG's forward acceleration peaks at 0.44 m/s², which asks the CoP (LIPM, CoG
0.88 m high) 4.0 cm beyond the CoG at the front turning point: 9.7 cm before the sole centres
(the CoG stands 1.2 cm before them), past the 9.35 cm `cop_inner` allows; the vertical sine
adds to it. The constraint, a level above the momentum, bounds the planned CoP and the CoG
tracking gives way. (At 6 cm the capture point, x + ẋ/ω₀, passes the bound: Talos fell.)

On a native tick the update runs in C++ (cpp/behaviours/squat.cpp; `native.py`).
"""

import numpy as np

from lab.controller.behaviours.balance import Balance
from lab.controller.model import RobotModel

try:
    from lab._kernel import Squat as NativeSquat
except ImportError:  # the native kernel is not built: every tick runs in Python
    NativeSquat = None

HOLD = 0.5  # s
AMPLITUDE = np.array([0.02, 0.0, 0.03])  # m: forward, sideways, vertical
PERIOD = 2.0  # s: 0.5 Hz
PERIOD_RANGE = (1.0, 5.0)  # s (the protocol allows cycle_time up to 5 s)


class Squat(Balance):
    """Stand on every foot with the CoG reference on a sine (module docstring)."""

    name = "squat"
    amplitude = AMPLITUDE

    def __init__(self, robot: RobotModel, q_standing: np.ndarray) -> None:
        super().__init__(robot, q_standing)
        self.centre = self.references.com.copy()
        self.period = PERIOD
        self.start: float | None = None
        self._native = NativeSquat() if NativeSquat is not None else None

    def configure(self, **options: object) -> None:
        """`cycle_time`: the sine's period (s) in PERIOD_RANGE; raises ValueError otherwise."""
        unknown = set(options) - {"cycle_time"}
        if unknown:
            raise ValueError(f"gait {self.name!r} takes no {', '.join(sorted(unknown))}")
        period = options.get("cycle_time", self.period)
        if not isinstance(period, int | float) or not PERIOD_RANGE[0] <= period <= PERIOD_RANGE[1]:
            raise ValueError(f"{self.name}: cycle_time must be in {PERIOD_RANGE} s, got {period!r}")
        self.period = float(period)
        self._native_stale = True

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Hold for HOLD s from the first tick, then move the CoG reference on the sine."""
        if self._native_tick(t, robot, command, touching):
            return
        self.start = t if self.start is None else self.start
        phase = max(t - self.start - HOLD, 0.0)
        omega = 2.0 * np.pi / self.period
        active = t - self.start >= HOLD
        refs = self.references
        refs.com[:] = self.centre + self.amplitude * np.sin(omega * phase)
        refs.com_velocity[:] = self.amplitude * omega * np.cos(omega * phase) * active
        refs.com_acceleration[:] = -self.amplitude * omega**2 * np.sin(omega * phase) * active


class CopSquat(Squat):
    """The squat of Fig. 10, far enough forward that the CoP constraints bind (module docstring)."""

    name = "squat_cop"
    amplitude = np.array([0.045, 0.0, 0.03])
