"""Contact forces estimated from joint torques (Raiola 2020 eq. 18), and the haptic touch
detector on them that stands in for the simulator's contact flags (docs/realism.md).

Per point foot, the leg's rows of the dynamics M q̈ + h = Sᵀτ + J_cᵀ F, solved for F on the
leg's 3 × 3 block J_c of the foot's contact Jacobian (world axes):
F_c = −J_c⁻ᵀ (τ_c − h_c − M_c q̈_c), τ_c the torques the leg's drives apply (a torque sensor's
reading), h_c the leg's bias forces and M_c its 3 × 3 block of the mass matrix, from the
controller's model at the measured state. Raiola's eq. 18 neglects the leg's acceleration q̈_c;
`ContactEstimator` keeps it, from the measured joint velocities differenced tick to tick and
low-passed: a swinging leg's deceleration at the end of its swing otherwise reads as a force
of the order of its share of the weight (ANYmal: 65 %). A flat foot (6 rows, a sole) or a leg
of other than three joints has no square block: its estimate is NaN and the session keeps the
simulator's touch flag for it.

The detector (Focchi 2020 as Raiola §4.3 uses it): a foot touches once its estimated normal
force exceeds `on` of its share of the weight and at least `min_force`, and lets go below
`off` (hysteresis). The gait accepts a touchdown only in the swing-down half of a swing
(lab/controller/behaviours/gait.py, Raiola §4.3), the expected-contact window. The thresholds
are per robot (`[touchdown]` in robots/<name>.toml).
"""

import math
from dataclasses import dataclass

import numpy as np

from lab.controller.model import BASE_DOF, RobotModel

G = 9.81


@dataclass(frozen=True)
class TouchThresholds:
    """When an estimated normal force is a touch: above `on` (fraction of the foot's share of
    the robot's weight) and `min_force` (N), until it falls below `off` (fraction); the joint
    accelerations are low-passed at `accel_filter_hz` (Hz; 0: unfiltered differences)."""

    on: float = 0.5
    off: float = 0.25
    min_force: float = 10.0
    accel_filter_hz: float = 100.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.off <= self.on:
            raise ValueError(f"touchdown thresholds need 0 <= off <= on, got {self}")
        if self.min_force < 0.0 or self.accel_filter_hz < 0.0:
            raise ValueError(f"touchdown min_force and accel_filter_hz must be >= 0, got {self}")


def _leg_joints(model: RobotModel, rows: slice) -> np.ndarray | None:
    """The joint indices (actuated order) of a point foot's leg: the nonzero columns of its
    contact Jacobian; None unless exactly three."""
    joints = np.flatnonzero(np.any(model.Jc[rows, BASE_DOF:] != 0.0, axis=0))
    return joints if joints.size == 3 else None


def estimated_contact_forces(
    model: RobotModel, applied_torques: np.ndarray, joint_accelerations: np.ndarray | None = None
) -> np.ndarray:
    """The force (n_contacts, 3), N, world axes, the terrain exerts on each foot, estimated
    from `applied_torques` (N m, pinocchio joint order) and `joint_accelerations` (rad/s²,
    same order; None: neglected, Raiola's eq. 18 as printed); NaN where not estimable."""
    out = np.full((len(model.contacts), 3), np.nan)
    for i, (contact, rows) in enumerate(zip(model.contacts, model.force_slices, strict=True)):
        if contact.kind != "point" or (joints := _leg_joints(model, rows)) is None:
            continue
        dof = BASE_DOF + joints
        residual = model.h[dof] - applied_torques[joints]
        if joint_accelerations is not None:
            residual = residual + model.M[np.ix_(dof, dof)] @ joint_accelerations[joints]
        out[i] = np.linalg.solve(model.Jc[rows, dof].T, residual)
    return out


class ContactEstimator:
    """Which feet touch, from the estimated contact forces (module docstring): keeps the last
    measured joint velocities, the filtered joint accelerations and each foot's touch state."""

    def __init__(self, thresholds: TouchThresholds, dt: float, n_joints: int, n_feet: int):
        if not dt > 0.0:
            raise ValueError(f"the control period must be > 0 s, got {dt}")
        self.thresholds, self.dt = thresholds, dt
        cutoff = thresholds.accel_filter_hz
        # first-order low-pass, discretized exactly: a = 1 − exp(−2π f dt)
        self._alpha = 1.0 if cutoff == 0.0 else 1.0 - math.exp(-2.0 * math.pi * cutoff * dt)
        self.velocity: np.ndarray | None = None  # rad/s, the last measured (None: no tick yet)
        self.accelerations = np.zeros(n_joints)  # rad/s², filtered
        self.touch = np.ones(n_feet, dtype=bool)  # a robot starts standing
        self.normal = np.zeros(n_feet)  # N, the last estimate's normal forces

    def take_state(
        self, velocity: np.ndarray | None, accelerations: np.ndarray, touch: np.ndarray
    ) -> None:
        """Continue from another estimator's state (the C++ twin's, on a switch of tick path)."""
        self.velocity = None if velocity is None else np.array(velocity, dtype=float)
        self.accelerations[:] = accelerations
        self.touch[:] = touch

    def update(
        self,
        model: RobotModel,
        applied_torques: np.ndarray,
        joint_velocities: np.ndarray,
        flags: np.ndarray,
    ) -> np.ndarray:
        """This tick's touch flags (bool per foot) from last tick's `applied_torques` (N m) and
        the measured `joint_velocities` (rad/s), at `model`'s measured state; a foot it cannot
        estimate keeps its `flags` (the simulator's)."""
        if self.velocity is not None:
            raw = (joint_velocities - self.velocity) / self.dt
            self.accelerations += self._alpha * (raw - self.accelerations)
        self.velocity = joint_velocities.copy()
        forces = estimated_contact_forces(model, applied_torques, self.accelerations)
        self.normal = normal = forces[:, 2]
        th = self.thresholds
        share = model.mass * G / len(model.contacts)
        on = max(th.on * share, th.min_force)
        off = th.off * share
        touch = np.where(self.touch, normal > off, normal > on)
        self.touch = np.where(np.isnan(normal), flags, touch)
        return self.touch.copy()
