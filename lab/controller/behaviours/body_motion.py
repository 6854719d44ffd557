"""Scripted body motions on four feet, the inputs of Hutter 2014 Sim5 and Exp6/Exp7.

- `height_step` (Sim5): after HOLD s, the body-height reference (CoM and base) steps down by
  HEIGHT_STEP, a step input: the knees take the load of decelerating the body.
- `forward_shift` (Exp6/7): after HOLD s, the CoM reference moves forward by SHIFT over SHIFT_TIME
  (minimum jerk) with body height and orientation held, driving the front hips (HFE) towards
  their limit.

On a native tick the update runs in C++ (cpp/behaviours/body_motion.cpp; `native.py`).
"""

import numpy as np

from lab.controller.behaviours.balance import standing_references
from lab.controller.behaviours.base import NoOptions
from lab.controller.behaviours.native import NativeTwin
from lab.controller.behaviours.static_walk import min_jerk
from lab.controller.model import RobotModel

try:
    from lab._kernel import ForwardShift as NativeForwardShift
    from lab._kernel import HeightStep as NativeHeightStep
except ImportError:  # the native kernel is not built: every tick runs in Python
    NativeForwardShift = NativeHeightStep = None

HOLD = 0.5  # s
HEIGHT_STEP = 0.08  # m, downwards
SHIFT = 0.25  # m, forwards
SHIFT_TIME = 2.0  # s


class HeightStep(NativeTwin, NoOptions):
    """Hutter 2014 Exp6: stand, then lower the body (CoM and base height) by HEIGHT_STEP m."""

    name = "height_step"
    lifts_feet = False

    def __init__(self, robot: RobotModel, q_standing: np.ndarray) -> None:
        self.references = standing_references(robot, q_standing)
        self.com = self.references.com.copy()
        self.height = self.references.base_height
        self.start: float | None = None
        self._native = NativeHeightStep() if NativeHeightStep is not None else None

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Hold for HOLD s from the first tick, then step the height references down."""
        if self._native_tick(t, robot, command, touching):
            return
        self.start = t if self.start is None else self.start
        drop = HEIGHT_STEP if t - self.start >= HOLD else 0.0
        self.references.com[:] = self.com - np.array([0.0, 0.0, drop])
        self.references.base_height = self.height - drop


class ForwardShift(NativeTwin, NoOptions):
    """Hutter 2014 Exp7: stand, then shift the CoM forward by SHIFT m on a minimum-jerk path."""

    name = "forward_shift"
    lifts_feet = False

    def __init__(self, robot: RobotModel, q_standing: np.ndarray) -> None:
        self.references = standing_references(robot, q_standing)
        self.com = self.references.com.copy()
        self.start: float | None = None
        self._native = NativeForwardShift() if NativeForwardShift is not None else None

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Hold for HOLD s from the first tick, then move the CoM reference forward over
        SHIFT_TIME s (position in m, world x; velocity in m/s)."""
        if self._native_tick(t, robot, command, touching):
            return
        self.start = t if self.start is None else self.start
        s, ds, _ = min_jerk((t - self.start - HOLD) / SHIFT_TIME)
        self.references.com[:] = self.com + np.array([SHIFT * s, 0.0, 0.0])
        self.references.com_velocity[:] = [SHIFT * ds / SHIFT_TIME, 0.0, 0.0]
