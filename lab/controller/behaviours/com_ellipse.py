"""The CoM on an ellipse over two point feet (Kim 2016 Fig. 6b): standing on a foot line, the
CoM reference walks an ellipse at constant rate in the vertical plane through that line,

    c_ref(t) = c₀ + A_u sin(ω t) u + A_z (cos(ω t) − 1) z,   ω = 2π / PERIOD,

u the horizontal unit vector from one foot to the other: Hume's sagittal ellipse, its feet
split fore and aft in the planarizer, is Bolt's along the line between its feet, the only
horizontal direction the CoM can move and stay balanced. The balance about the foot line
(`line_balance.py`) still leans the reference across it. Sizes are Hume's scaled by CoM height
(Bolt 0.3 m, Hume taken as 1 m): 1.5 cm along, 1 cm up, one turn in 4 s after HOLD s.

On a native tick the update runs in C++ (cpp/behaviours/com_ellipse.cpp; `native.py`).
"""

import numpy as np

from lab.controller.behaviours.balance import Balance
from lab.controller.model import RobotModel

try:
    from lab._kernel import ComEllipse as NativeComEllipse
except ImportError:  # the native kernel is not built: every tick runs in Python
    NativeComEllipse = None

HOLD = 0.5  # s
AMPLITUDE_ALONG = 0.015  # m, along the foot line
AMPLITUDE_UP = 0.01  # m
PERIOD = 4.0  # s
Z = np.array([0.0, 0.0, 1.0])


class ComEllipse(Balance):
    """Stand on two point feet with the CoM reference on the ellipse of the module docstring."""

    name = "com_ellipse"

    def __init__(self, robot: RobotModel, q_standing: np.ndarray) -> None:
        super().__init__(robot, q_standing)
        if not self._on_line:
            raise ValueError("com_ellipse needs a robot standing on two point feet")
        a, b = robot.contact_positions
        along = (b - a) * np.array([1.0, 1.0, 0.0])
        self.along = along / np.linalg.norm(along)
        self.centre = self._com_on_line.copy()
        self.start: float | None = None
        self._native = NativeComEllipse() if NativeComEllipse is not None else None

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Balance about the foot line, the CoM reference moved along the ellipse."""
        if self._native_tick(t, robot, command, touching):
            return
        self.start = t if self.start is None else self.start
        phase = 2.0 * np.pi / PERIOD * max(t - self.start - HOLD, 0.0)
        rate = 2.0 * np.pi / PERIOD * (t - self.start >= HOLD)
        s, c = np.sin(phase), np.cos(phase)
        self._com_on_line[:] = self.centre + AMPLITUDE_ALONG * s * self.along
        self._com_on_line += AMPLITUDE_UP * (c - 1.0) * Z
        self._lean(robot)
        self.references.com_velocity[:] = rate * (
            AMPLITUDE_ALONG * c * self.along - AMPLITUDE_UP * s * Z
        )
