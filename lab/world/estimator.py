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
Runs on the session's Python tick (no C++ twin yet: the native tick does not call it).
"""

import math

import numpy as np
import pinocchio as pin

from lab.estimation.filter import LeggedEkf
from lab.estimation.measurement import LegKinematics
from lab.realism.accelerometer import Accelerometer, base_rotation
from lab.realism.knobs import RealismKnobs
from lab.robot import Robot

BASE_Q, BASE_V = 7, 6  # free-flyer coordinates of q and v


def _yaw(rotation: np.ndarray) -> float:
    return math.atan2(rotation[1, 0], rotation[0, 0])


class BaseEstimator:
    """The controller's view of the base under `knobs.estimator`, for `robot` ticked every
    `dt` s (module docstring)."""

    def __init__(self, knobs: RealismKnobs, robot: Robot, dt: float) -> None:
        self.name = knobs.estimator
        self.accelerometer: Accelerometer | None = None
        self.filter: LeggedEkf | None = None
        if self.name == "ekf":
            gravity = np.array(robot.model.gravity.linear)
            self.accelerometer = Accelerometer(knobs, dt, gravity)
            kinematics = LegKinematics(robot.model, [c.frame for c in robot.contacts])
            radii = np.array([c.radius if c.kind == "point" else 0.0 for c in robot.contacts])
            self.filter = LeggedEkf(kinematics, radii, gravity, dt)
        self.truth: tuple[np.ndarray, np.ndarray] | None = None  # the last read's
        self.estimate: tuple[np.ndarray, np.ndarray] | None = None

    def reset(self, q: np.ndarray, v: np.ndarray) -> None:
        """A new run from the true state (q, v): the filter starts there (the lab's world frame
        is the start's), nothing read yet."""
        if self.filter is not None and self.accelerometer is not None:
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
        if self.filter is None or self.accelerometer is None or contacts is None:
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

    def report(self, exact: bool = False) -> dict:
        """Telemetry's `estimator`: which ran, and the last read's estimate − truth: base
        position and linear velocity (world axes), yaw and whole orientation (rad); zeros when
        `exact` (the controller read the true state itself: the native tick) or before a read."""
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
