"""What the controller reads of the base, and how far it is from the truth (issue 30 item 1,
docs/realism.md "The state estimator").

The realism knob `estimator` picks it: `true`, the realism layer's measured state (the true
state through its delay and noise: the base's position and velocity noise stand in for an
estimator); `ekf`, the base's pose and twist estimated by lab/estimation's EKF from the IMU (the
layer's gyroscope, lab/realism/accelerometer.py's accelerometer) and the leg kinematics (the
layer's encoders) of the feet the controller has in contact (its references' `contact_active`:
the behaviour's schedule and touchdowns, not MuJoCo's contact flags), the joints still the
layer's. Either way it keeps the truth of the tick beside what the controller read:
telemetry's `estimator` reports the errors.
Where lab._kernel is built, the EKF and the accelerometer run there (`EkfEstimator`,
cpp/estimation: the same arithmetic and draws, tests/estimation/test_ekf_native.py): the native
tick calls it inside its one crossing (lab/world/native_tick.py), a Python tick through `read`,
so the filter's state lives in one place whichever tick runs.
"""

import math
from typing import Any

import numpy as np
import pinocchio as pin

from lab.estimation.filter import LeggedEkf
from lab.estimation.measurement import LegKinematics
from lab.realism.accelerometer import Accelerometer, base_rotation
from lab.realism.knobs import RealismKnobs
from lab.robot import Robot

try:
    from lab import _kernel
except ImportError:  # not built: the Python filter runs
    _kernel = None

BASE_Q, BASE_V = 7, 6  # free-flyer coordinates of q and v


def _yaw(rotation: np.ndarray) -> float:
    return math.atan2(rotation[1, 0], rotation[0, 0])


class BaseEstimator:
    """The controller's view of the base under `knobs.estimator`, for `robot` ticked every
    `dt` s (module docstring): under `ekf`, the C++ twin (`native`) when lab._kernel is built
    and `native` is True, else the Python filter (`filter`)."""

    def __init__(self, knobs: RealismKnobs, robot: Robot, dt: float, native: bool = True) -> None:
        self.name = knobs.estimator
        self.accelerometer: Accelerometer | None = None
        self.filter: LeggedEkf | None = None
        self.native: Any = None  # lab._kernel.EkfEstimator, when the twin runs
        if self.name == "ekf":
            gravity = np.array(robot.model.gravity.linear)
            frames = [c.frame for c in robot.contacts]
            radii = np.array([c.radius if c.kind == "point" else 0.0 for c in robot.contacts])
            if native and _kernel is not None:
                self.native = _kernel.EkfEstimator(
                    robot.model.saveToString(), frames, radii, gravity, dt, knobs.values()
                )
            else:
                self.accelerometer = Accelerometer(knobs, dt, gravity)
                self.filter = LeggedEkf(LegKinematics(robot.model, frames), radii, gravity, dt)
        self.truth: tuple[np.ndarray, np.ndarray] | None = None  # the last read's
        self.estimate: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def active(self) -> bool:
        """Whether the base the controller reads is estimated (`ekf`), in either kernel."""
        return self.filter is not None or self.native is not None

    def reset(self, q: np.ndarray, v: np.ndarray) -> None:
        """A new run from the true state (q, v): the filter starts there (the lab's world frame
        is the start's), nothing read yet."""
        if self.native is not None:
            self.native.reset(q, v)
        elif self.filter is not None and self.accelerometer is not None:
            self.accelerometer.reset(q, v)
            self.filter.reset(q, v)
        self.truth = self.estimate = None

    def read(
        self,
        truth: tuple[np.ndarray, np.ndarray],
        measured: tuple[np.ndarray, np.ndarray],
        contacts: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The state (q, v) the controller reads this tick, from the `truth` and the realism
        layer's `measured` state (pinocchio's conventions), `contacts` the feet the controller
        has in contact (the `true` estimator reads none)."""
        if contacts is not None and self.native is not None:
            estimate = self.native.read(*truth, *measured, np.asarray(contacts, dtype=bool))
        elif self.filter is None or self.accelerometer is None or contacts is None:
            estimate = measured
        else:
            qm, vm = measured
            gyro = vm[3:BASE_V]  # the layer's gyroscope: ω + bias + noise
            accel = self.accelerometer.measure(*truth)
            self.filter.step(accel, gyro, qm[BASE_Q:], vm[BASE_V:], contacts)
            estimate = (
                self.filter.configuration(qm[BASE_Q:]),
                self.filter.velocity(gyro, vm[BASE_V:]),
            )
        self.truth, self.estimate = truth, estimate
        return estimate

    def read_elsewhere(
        self, truth: tuple[np.ndarray, np.ndarray], estimate: tuple[np.ndarray, np.ndarray]
    ) -> None:
        """The native tick read (q, v) `estimate` at the true state `truth` (views of its
        buffers and of the model's arrays, current until the next tick): `report` uses them."""
        self.truth, self.estimate = truth, estimate

    def report(self, exact: bool = False) -> dict:
        """Telemetry's `estimator`: which ran, and the last read's estimate − truth: base
        position and linear velocity (world axes), yaw and whole orientation (rad); zeros when
        `exact` (the controller read the true state itself: a native tick without the EKF) or
        before a read."""
        errors = {
            "position_error": [0.0] * 3,
            "velocity_error": [0.0] * 3,
            "yaw_error": 0.0,
            "orientation_error": 0.0,
        }
        if not exact and self.truth is not None and self.estimate is not None:
            (q, v), (qe, ve) = self.truth, self.estimate
            rotation, estimated = base_rotation(q), base_rotation(qe)
            yaw = _yaw(estimated) - _yaw(rotation)
            errors = {
                "position_error": (qe[:3] - q[:3]).tolist(),
                "velocity_error": (estimated @ ve[:3] - rotation @ v[:3]).tolist(),
                "yaw_error": math.atan2(math.sin(yaw), math.cos(yaw)),
                "orientation_error": float(np.linalg.norm(pin.log3(rotation.T @ estimated))),
            }
        return {"name": self.name, **errors}
