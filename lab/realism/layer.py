"""The realism layer between the plant and the controller (cpp/realism/layer.cpp mirrors it).

Per tick, `measure(q, v)` turns the true state into the measured one (measurement delay, then
the IMU and encoder models, noise drawn from the seed and the tick: lab/realism/rng.py) and
`actuate(τ_cmd, q, v)` turns the controller's torques into the joint torques the plant applies
(command delay, then the actuator model). The controller reads only `measured`: issue 30's
state estimator will sit where `measure` is (its seam). Torque saturation and joint friction
are the plant's (MuJoCo's ctrlrange, frictionloss and damping: `MujocoPlant.set_drive_limits`);
model error is the controller model's (model_error.py). `realism_layer` picks the C++ twin
(`NativeRealismLayer`) when lab._kernel is built: the same numbers, a tenth of the cost.
"""

import numpy as np

from lab.realism.actuators import Actuator, FirstOrderTorque, SeriesElastic
from lab.realism.delays import DelayLine
from lab.realism.knobs import RealismKnobs
from lab.realism.rng import normals
from lab.realism.sensors import IMU_DRAWS, Encoders, Imu

try:  # the per-tick work in C++ (cpp/realism); without it the Python layer below runs
    from lab import _kernel
except ImportError:
    _kernel = None

BASE_Q, BASE_V = 7, 6  # free-flyer coordinates of q and v


class RealismLayer:
    """Sensors, delays and actuators of `knobs` for a robot with `na` joints, tick `dt` s."""

    kernel = "python"

    def __init__(self, knobs: RealismKnobs, na: int, dt: float) -> None:
        self.knobs, self.na = knobs, na
        self.width = IMU_DRAWS + na  # normals per tick
        self.imu = Imu(knobs, dt)
        self.encoders = Encoders(knobs, na, dt)
        self.state_delay = DelayLine(knobs.measurement_delay, BASE_Q + na + BASE_V + na)
        self.command_delay = DelayLine(knobs.command_delay, na)
        models = {"bandwidth": FirstOrderTorque, "sea": SeriesElastic}
        self.actuator: Actuator | None = (
            models[knobs.actuator](knobs, na, dt) if knobs.actuator in models else None
        )
        self.tick = 0
        self.noisy = any(
            value > 0.0
            for value in (
                knobs.gyro_noise,
                knobs.gyro_bias_walk,
                knobs.attitude_noise,
                knobs.base_velocity_noise,
                knobs.base_position_noise,
                knobs.encoder_noise,
            )
        )
        # measure and actuate change nothing: the session skips them
        self.ideal = (
            not self.noisy
            and knobs.encoder_bits == 0
            and not knobs.velocity_differencing
            and knobs.measurement_delay == 0
            and knobs.command_delay == 0
            and self.actuator is None
        )

    def reset(self, q: np.ndarray, tau: np.ndarray | None = None) -> None:
        """A new run from configuration `q` at rest, the actuators carrying `tau` (N m)."""
        self.tick = 0
        self.imu.reset()
        self.encoders.reset()
        self.state_delay.reset()
        self.command_delay.reset()
        tau = np.zeros(self.na) if tau is None else tau
        if isinstance(self.actuator, SeriesElastic):
            self.actuator.reset(q[BASE_Q:], tau)
        elif self.actuator is not None:
            self.actuator.reset(tau)

    def measure(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The state the controller reads this tick, from the true (q, v) (new arrays)."""
        nq = q.size
        delayed = self.state_delay.push(np.concatenate((q, v)))
        qm, vm = delayed[:nq], delayed[nq:]
        noise = (
            normals(self.knobs.seed, self.tick * self.width, self.width)
            if self.noisy
            else np.zeros(self.width)
        )
        self.tick += 1
        self.imu.measure(qm, vm, noise[:IMU_DRAWS])
        self.encoders.measure(qm[BASE_Q:], vm[BASE_V:], noise[IMU_DRAWS:])
        return qm, vm

    def actuate(self, command: np.ndarray, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The joint torques (N m) the plant applies this tick for the controller's `command`,
        given the true state (q, v) (the SEA's spring reads the joint)."""
        delayed = self.command_delay.push(command)
        if self.actuator is None:
            return delayed
        return self.actuator.apply(delayed, q[BASE_Q:], v[BASE_V:])


class NativeRealismLayer:
    """`RealismLayer` whose per-tick work runs in lab._kernel.RealismLayer (cpp/realism/layer.cpp:
    the same draws and arithmetic, tests/realism/test_realism_native.py); `knobs` and `ideal` as
    there."""

    kernel = "native"

    def __init__(self, knobs: RealismKnobs, na: int, dt: float) -> None:
        self.knobs, self.na = knobs, na
        # the C++ layer itself: the session's native tick drives it (lab/world/native_tick.py)
        self.native = _kernel.RealismLayer(knobs.values(), na, dt)
        self.ideal = self.native.ideal
        self.measure = self.native.measure  # (q, v) -> (q, v) measured
        self.actuate = self.native.actuate  # (command, q, v) -> joint torques

    def reset(self, q: np.ndarray, tau: np.ndarray | None = None) -> None:
        """A new run from configuration `q` at rest, the actuators carrying `tau` (N m)."""
        self.native.reset(q, np.zeros(self.na) if tau is None else tau)


def realism_layer(
    knobs: RealismKnobs, na: int, dt: float, native: bool = True
) -> RealismLayer | NativeRealismLayer:
    """The layer for `knobs`: in lab._kernel when it is built and `native`, else in Python
    (its `kernel` says which)."""
    if native and _kernel is not None:
        return NativeRealismLayer(knobs, na, dt)
    return RealismLayer(knobs, na, dt)
