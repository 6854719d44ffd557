"""Actuator models from the commanded to the joint torque (cpp/realism/actuators.cpp).

- `FirstOrderTorque`: τ̇ = 2π f (τ_cmd − τ), exact for a command held over the tick.
- `SeriesElastic` (StarlETH, ANYmal's ANYdrive, Hume): a motor of inertia J behind a spring of
  stiffness k, J θ̈ = τ_m − k (θ − q), under a motor-side PD on the spring deflection
  δ = θ − q towards δ_d = τ_cmd / k, with the command fed forward:
  τ_m = τ_cmd + K_p (δ_d − δ) + K_d (q̇ − θ̇). With the joint held, δ follows
  J δ̈ + K_d δ̇ + (K_p + k) δ = (K_p + k) δ_d: ω_n = √((K_p + k)/J), ζ = K_d / (2 √((K_p + k) J)),
  no steady-state error. The joint torque is k δ. **This layer integrates the motor state**
  (implicit Euler, SEA_SUBSTEPS per tick, the joint's q and q̇ held from the tick's start); the
  plant sees only the spring torque, through its torque motors.
"""

import math

import numpy as np

from lab.realism.knobs import RealismKnobs

SEA_SUBSTEPS = 10  # implicit Euler steps per tick: 0.1 ms at 1 kHz, within 1 % of the exact rise


class FirstOrderTorque:
    """A first-order lag of bandwidth f Hz on each joint's torque."""

    def __init__(self, knobs: RealismKnobs, na: int, dt: float) -> None:
        self.alpha = 1.0 - math.exp(-2.0 * math.pi * knobs.torque_bandwidth_hz * dt)
        self.tau = np.zeros(na)

    def reset(self, tau: np.ndarray) -> None:
        """Start at torque `tau` (N m)."""
        self.tau[:] = tau

    def apply(self, command: np.ndarray, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The joint torque this tick for `command` (q, v unused: a torque source)."""
        self.tau += self.alpha * (command - self.tau)
        return self.tau.copy()


class SeriesElastic:
    """The SEA of the module docstring, one per joint, with the same parameters."""

    def __init__(self, knobs: RealismKnobs, na: int, dt: float) -> None:
        self.k, self.inertia = knobs.sea_stiffness, knobs.sea_motor_inertia
        self.kp, self.kd = knobs.sea_kp, knobs.sea_kd
        self.h = dt / SEA_SUBSTEPS
        self.theta = np.zeros(na)  # motor angle through the gear (rad)
        self.omega = np.zeros(na)  # its rate (rad/s)

    def reset(self, qj: np.ndarray, tau: np.ndarray) -> None:
        """Motor at rest, its spring deflected to carry `tau` at joint angles `qj`."""
        self.theta[:] = qj + tau / self.k
        self.omega[:] = 0.0

    def apply(self, command: np.ndarray, qj: np.ndarray, vj: np.ndarray) -> np.ndarray:
        """Advance the motors one tick under `command`; the spring torque k (θ − q) (N m)."""
        k, kp, kd, h = self.k, self.kp, self.kd, self.h
        drive = command + kp * command / k + kd * vj  # τ_cmd + K_p δ_d + K_d q̇
        scale = 1.0 / (self.inertia + h * kd + h * h * (kp + k))
        for _ in range(SEA_SUBSTEPS):  # ω' from J(ω' − ω)/h = drive − K_d ω' − (K_p + k)(δ + hω')
            self.omega = scale * (
                self.inertia * self.omega + h * (drive - (kp + k) * (self.theta - qj))
            )
            self.theta = self.theta + h * self.omega
        return k * (self.theta - qj)


Actuator = FirstOrderTorque | SeriesElastic
