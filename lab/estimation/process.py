"""The process model: the nominal state propagated by the IMU over one tick, and the error's
transition and noise (Bloesch et al. 2013's model; its error-state discretization to first
order as Solà 2017 §5.4, local angular error).

With â = f̃ − b̂_a and ω̂ = ω̃ − b̂_g the bias-corrected accelerometer and gyroscope readings
(base frame) and g gravity (world), over a tick dt:

    p ← p + v dt + ½ (R â + g) dt²     v ← v + (R â + g) dt     R ← R Exp(ω̂ dt)
    d_i ← d_i + (ω_i × r_i e_z) dt for a foot in contact, d_i the centre of a sphere of radius
          r_i rolling on level ground at the world angular velocity ω_i of its link (0 for a
          point foot or a sole); b_a, b_g unchanged (the biases random-walk)

and the error δx ← F δx + w:

    δp ← δp + δv dt
    δv ← δv − R [â]× δθ dt − R δb_a dt + w_v,   w_v ~ N(0, σ_a² dt)
    δθ ← Exp(ω̂ dt)ᵀ δθ − δb_g dt + w_θ,         w_θ ~ N(0, σ_g² dt)
    δd_i ← δd_i + w_d, w_d ~ N(0, σ_d² dt) for a foot in contact (its slip); a swinging foot's
          error is left alone, its part of x is re-made at its touchdown (measurement.py)
    δb_a ← δb_a + w_ba, δb_g ← δb_g + w_bg,      N(0, σ_ba² dt), N(0, σ_bg² dt)

σ_a, σ_g, σ_ba, σ_bg, σ_d are continuous densities (units/√Hz), the filter's tuning.
"""

import numpy as np
import pinocchio as pin

from lab.estimation.state import ErrorLayout, NominalState
from lab.estimation.tuning import EkfTuning


def propagate(
    x: NominalState, accel: np.ndarray, gyro: np.ndarray, gravity: np.ndarray, dt: float
) -> None:
    """Advance `x` in place by one tick of IMU readings `accel` (m/s²) and `gyro` (rad/s)."""
    world_accel = x.rotation @ (accel - x.accel_bias) + gravity
    x.position += x.velocity * dt + 0.5 * world_accel * dt * dt
    x.velocity += world_accel * dt
    x.rotation = x.rotation @ pin.exp3((gyro - x.gyro_bias) * dt)


def roll_feet(
    x: NominalState,
    spins: np.ndarray,
    gyro: np.ndarray,
    radii: np.ndarray,
    stance: np.ndarray,
    dt: float,
) -> None:
    """Move the centres of the rolling feet in `stance` in place: each link's world angular
    velocity R (ω̂ + `spins`_i) (its spin relative to the base, base frame), crossed with
    r_i e_z (module docstring)."""
    omega = (spins + (gyro - x.gyro_bias)) @ x.rotation.T  # (n, 3), world
    lever = np.outer(radii, [0.0, 0.0, 1.0])
    x.feet += dt * stance[:, None] * np.cross(omega, lever)


def transition(
    x: NominalState, accel: np.ndarray, gyro: np.ndarray, dt: float, layout: ErrorLayout
) -> np.ndarray:
    """F of the module docstring, at `x` before it is propagated."""
    F = np.eye(layout.size)
    R = x.rotation
    F[layout.p, layout.v] = dt * np.eye(3)
    F[layout.v, layout.theta] = -dt * R @ pin.skew(accel - x.accel_bias)
    F[layout.v, layout.accel_bias] = -dt * R
    F[layout.theta, layout.theta] = pin.exp3((gyro - x.gyro_bias) * dt).T
    F[layout.theta, layout.gyro_bias] = -dt * np.eye(3)
    return F


def process_noise(
    tuning: EkfTuning, stance: np.ndarray, dt: float, layout: ErrorLayout
) -> np.ndarray:
    """The diagonal of Q for one tick: the tuning's densities squared times dt, the foot slip
    on the feet in `stance` only."""
    q = np.zeros(layout.size)
    q[layout.v] = tuning.accel_noise**2 * dt
    q[layout.theta] = tuning.gyro_noise**2 * dt
    q[layout.accel_bias] = tuning.accel_bias_walk**2 * dt
    q[layout.gyro_bias] = tuning.gyro_bias_walk**2 * dt
    for foot, standing in zip(layout.feet, stance, strict=True):
        if standing:
            q[foot] = tuning.foot_slip**2 * dt
    return q
