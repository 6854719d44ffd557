"""Sensor models between the true state and what the controller reads (cpp/realism/sensors.cpp).

`Imu`: the base's attitude, angular velocity (gyro: white noise and a bias that random-walks),
and, standing in for the state estimator until issue 30's EKF replaces them, the base's position
and linear velocity with white noise. `Encoders`: joint angles with noise and quantization, and
joint velocities either true or by differencing the encoders, low-passed. Discrete noise from
continuous densities as in Kalibr's IMU model: white σ_d = σ_c / √dt, random walk σ_d = σ_c √dt.
Every draw comes from the caller (`noise`: standard normals of lab/realism/rng.py).
"""

import math

import numpy as np
import pinocchio as pin

from lab.realism.knobs import RealismKnobs

IMU_DRAWS = 15  # attitude 3, gyro white 3, gyro bias walk 3, linear velocity 3, position 3


class Imu:
    """The base part of the measured state (pinocchio conventions: v in the base frame)."""

    def __init__(self, knobs: RealismKnobs, dt: float) -> None:
        self.attitude = knobs.attitude_noise
        self.gyro = knobs.gyro_noise / math.sqrt(dt)
        self.bias_step = knobs.gyro_bias_walk * math.sqrt(dt)
        self.velocity = knobs.base_velocity_noise
        self.position = knobs.base_position_noise
        self.bias = np.zeros(3)

    def reset(self) -> None:
        """A new run: no gyro bias yet."""
        self.bias[:] = 0.0

    def measure(self, q: np.ndarray, v: np.ndarray, noise: np.ndarray) -> None:
        """Corrupt the base entries of (q, v) in place with IMU_DRAWS normals `noise`."""
        if self.attitude > 0.0:  # R_meas = R exp(δθ), δθ in the base frame
            rotation = pin.Quaternion(q[6], q[3], q[4], q[5]).matrix()
            turned = pin.Quaternion(rotation @ pin.exp3(self.attitude * noise[0:3]))
            turned.normalize()
            q[3:7] = turned.coeffs()
        self.bias += self.bias_step * noise[6:9]
        v[3:6] += self.bias + self.gyro * noise[3:6]
        v[0:3] += self.velocity * noise[9:12]
        q[0:3] += self.position * noise[12:15]


class Encoders:
    """The joint part of the measured state: q_j quantized to 2π / 2^bits after noise; v_j
    true, or differenced from the measured q_j and low-passed (first order, exact for a held
    input: α = 1 − exp(−2π f dt))."""

    def __init__(self, knobs: RealismKnobs, na: int, dt: float) -> None:
        self.noise = knobs.encoder_noise
        self.resolution = 2.0 * math.pi / 2.0**knobs.encoder_bits if knobs.encoder_bits else 0.0
        self.differencing = bool(knobs.velocity_differencing)
        f = knobs.velocity_filter_hz
        self.alpha = 1.0 - math.exp(-2.0 * math.pi * f * dt) if f > 0.0 else 1.0
        self.dt = dt
        self.previous = np.zeros(na)
        self.velocity = np.zeros(na)
        self.started = False

    def reset(self) -> None:
        """A new run: the next measurement starts the differences (velocity 0)."""
        self.velocity[:] = 0.0
        self.started = False

    def measure(self, qj: np.ndarray, vj: np.ndarray, noise: np.ndarray) -> None:
        """Corrupt joint angles `qj` and velocities `vj` in place with na normals `noise`."""
        qj += self.noise * noise
        if self.resolution > 0.0:
            qj[:] = np.rint(qj / self.resolution) * self.resolution
        if not self.differencing:
            return
        if self.started:
            self.velocity += self.alpha * ((qj - self.previous) / self.dt - self.velocity)
        self.previous[:] = qj
        self.started = True
        vj[:] = self.velocity
