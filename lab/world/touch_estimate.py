"""Realism's touch detector (the `contact_estimate` knob, lab/realism/contact_estimate.py) on
whichever tick runs.

Where lab._kernel is built, the detector's state (last joint velocities, filtered accelerations,
touch flags) lives in its C++ twin (`lab._kernel.ContactEstimator`, cpp/realism/
contact_estimate.cpp), which the native tick runs inside its one crossing
(`ServerTick.set_touch_estimator`, set when the knob turns on or the robot stands again); a
Python tick loads that state into the Python detector, updates it (the reference) and stores it
back, so a switch of tick path continues the same detector. The twin reads last tick's torques
from the native tick's `applied` buffer: a tick that ran in Python writes it
(`NativeTick.applied_elsewhere`).
"""

from typing import Any

import numpy as np

from lab.controller.model import RobotModel
from lab.realism.contact_estimate import ContactEstimator, TouchThresholds
from lab.world.native_tick import NativeTick

try:
    from lab import _kernel
except ImportError:  # not built: the Python detector alone
    _kernel = None


class TouchEstimate:
    """The touch detector of a session with `contact_estimate` on (module docstring), for a
    robot of `n_joints` joints and `n_feet` feet ticked every `dt` s; installed in
    `native_tick`'s crossing, which last applied `applied` (N m)."""

    def __init__(
        self,
        thresholds: TouchThresholds,
        dt: float,
        n_joints: int,
        n_feet: int,
        native_tick: NativeTick,
        applied: np.ndarray,
    ) -> None:
        self.python = ContactEstimator(thresholds, dt, n_joints, n_feet)
        self.native: Any = None  # lab._kernel.ContactEstimator, where built
        if _kernel is not None:
            self.native = _kernel.ContactEstimator(
                **vars(thresholds), dt=dt, n_joints=n_joints, n_feet=n_feet
            )
        native_tick.set_touch_estimator(self.native)
        native_tick.applied_elsewhere(applied)

    @property
    def touch(self) -> np.ndarray:
        """Each foot's touch flag after the last update, on either tick path."""
        return self.python.touch if self.native is None else self.native.touch

    def update(
        self,
        model: RobotModel,
        applied: np.ndarray,
        joint_velocities: np.ndarray,
        flags: np.ndarray,
    ) -> np.ndarray:
        """A Python tick's touch flags: `ContactEstimator.update` continuing the twin's state."""
        python, native = self.python, self.native
        if native is not None:
            python.take_state(native.velocity, native.accelerations, native.touch)
        touch = python.update(model, applied, joint_velocities, flags)
        if native is not None:
            native.take_state(python.velocity, python.accelerations, python.touch)
        return touch
