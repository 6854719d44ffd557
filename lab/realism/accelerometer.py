"""The IMU's accelerometer, which the state estimator reads (issue 30 item 1; its C++ twin,
cpp/realism/accelerometer.cpp, draws the same numbers inside lab._kernel's EkfEstimator).

It measures the specific force at the base origin in the base frame, f = Rᵀ (a − g), from the
plant's true motion: a is the base's mean acceleration over the last tick,
(R_k v_k − R_{k−1} v_{k−1}) / dt in world axes (a strapdown IMU's Δv output; v is pinocchio's
base-frame linear velocity), Rᵀ the base orientation at the tick's start. Noise as the gyro's
(Kalibr's discrete model): white σ_d = σ_c / √dt and a bias that random-walks σ_c √dt per tick,
knobs `accel_noise` and `accel_bias_walk`. Its draws come from the seed's own stream
(ACCEL_STREAM), so the layer's draws (lab/realism/layer.py) are the same with or without it. The
reading goes through the measurement delay, as the rest of the IMU.
"""

import math

import numpy as np
import pinocchio as pin

from lab.realism.delays import DelayLine
from lab.realism.knobs import RealismKnobs
from lab.realism.rng import normals

ACCEL_STREAM = 0x616363656C  # "accel": the accelerometer's draws, apart from the layer's
ACCEL_DRAWS = 6  # white 3, bias walk 3


def base_rotation(q: np.ndarray) -> np.ndarray:
    """The base's rotation (base → world) of configuration `q` (quaternion x, y, z, w)."""
    return pin.Quaternion(q[6], q[3], q[4], q[5]).matrix()


class Accelerometer:
    """The accelerometer of the module docstring, for a tick of `dt` s under `gravity` (m/s²,
    world axes)."""

    def __init__(self, knobs: RealismKnobs, dt: float, gravity: np.ndarray) -> None:
        self.seed, self.dt, self.gravity = knobs.seed, dt, gravity
        self.white = knobs.accel_noise / math.sqrt(dt)
        self.bias_step = knobs.accel_bias_walk * math.sqrt(dt)
        self.noisy = self.white > 0.0 or self.bias_step > 0.0
        self.delay = DelayLine(knobs.measurement_delay, 3)
        self.bias = np.zeros(3)
        self.rotation = np.eye(3)
        self.velocity = np.zeros(3)  # world axes, the last tick's
        self.tick = 0

    def reset(self, q: np.ndarray, v: np.ndarray) -> None:
        """A new run from the true state (q, v): no bias, no reading delayed yet."""
        self.rotation = base_rotation(q)
        self.velocity = self.rotation @ v[:3]
        self.bias[:] = 0.0
        self.delay.reset()
        self.tick = 0

    def measure(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The reading (m/s², base frame) at the true state (q, v) of this tick."""
        rotation = base_rotation(q)
        velocity = rotation @ v[:3]
        force = self.rotation.T @ ((velocity - self.velocity) / self.dt - self.gravity)
        self.rotation, self.velocity = rotation, velocity
        if self.noisy:
            noise = normals(self.seed ^ ACCEL_STREAM, self.tick * ACCEL_DRAWS, ACCEL_DRAWS)
            self.bias += self.bias_step * noise[3:]
            force += self.bias + self.white * noise[:3]
        self.tick += 1
        return self.delay.push(force)
