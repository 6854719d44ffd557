"""Balance about the line between two point feet, where no ankle torque exists.

Every contact force passes through the foot line, so the angular momentum L_u about it changes
only by gravity: L̇_u = m g d, with d the horizontal offset of the CoM from the line, across it.
The CoM can still be held anywhere (the legs move it), but holding it over the line leaves L_u
and the body's rotation about the line drifting (its zero dynamics). This law moves the CoM
reference off the line by

    d_ref = −(2ζω L_u + ω² I_u θ_u) / (m g)

so that, with the CoM task tracking, I_u θ̈_u = L̇_u = −2ζω I_u θ̇_u − ω² I_u θ_u: the base's
rotation error θ_u about the line and L_u settle like a damped oscillator (the body acts as a
reaction wheel through gravity, as a point-foot robot must). Kim 2016 keeps Hume on the line in
a planarizer and with a soft CoM_x gain (Table I: K_x = 15); in 3-D it steps (§V).
"""

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from lab.controller.model import RobotModel

Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class LineBalanceGains:
    """ω (rad/s) and ζ of the rotation about the foot line; `max_offset` (m) bounds d_ref."""

    omega: float = 3.0
    damping: float = 1.0
    max_offset: float = 0.03


def composite_inertia(robot: RobotModel) -> np.ndarray:
    """The whole body's rotational inertia about its CoM (world axes, kg m²) at the state of
    the last `update` of `robot` (pinocchio's composite rigid body inertia)."""
    pin.ccrba(robot.model, robot.data, robot.q, robot.v)
    return robot.data.Ig.inertia.copy()


def line_balance_offset(
    robot: RobotModel,
    feet: tuple[int, int],
    base_rotation_ref: np.ndarray,
    inertia: np.ndarray,
    gains: LineBalanceGains,
) -> np.ndarray:
    """The horizontal CoM offset (world, m) from the foot line that the law above asks for."""
    a, b = robot.contact_positions[list(feet)]
    u = (b - a) / np.linalg.norm(b - a)
    across = np.cross(u, Z)  # L̇_u = m g (c − p)·across
    c, p = robot.com, 0.5 * (a + b)
    momentum = robot.centroidal_momentum()
    L = momentum[3:] + np.cross(c - p, momentum[:3])  # about the line's midpoint
    rotation_error = pin.log3(robot.base_rotation @ base_rotation_ref.T)  # world axes
    inertia_u = float(u @ inertia @ u)
    weight = robot.mass * float(np.linalg.norm(robot.gravity))
    w, zeta = gains.omega, gains.damping
    d = -(2.0 * zeta * w * (u @ L) + w * w * inertia_u * (u @ rotation_error)) / weight
    return float(np.clip(d, -gains.max_offset, gains.max_offset)) * across
