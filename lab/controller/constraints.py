"""Constraints: inequality rows `C x ≤ d` over x = [q̈, F].

In a strict stack a constraint sits at a level like a task; the cascade gives it a slack there and
keeps the slack it reached for every level below (Herzog eqs. 9–11).
"""

from dataclasses import dataclass
from functools import cache

import numpy as np

from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.references import References
from lab.controller.rows import PerContactSet, read_only


@dataclass
class ContactLimits:
    """Friction and normal-force bounds shared by every contact of a robot."""

    friction: float = 0.8
    normal_min: float = 0.0
    normal_max: float = 5000.0


def _rows(n: int, robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((n, robot.nx)), np.zeros(n)


class Constraint:
    """Base class: a named producer of inequality rows."""

    name: str = ""

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        """This tick's rows (C, d) of C x ≤ d over x = [q̈, F], at the state of the last
        `robot.update` and the contact set of `refs`."""
        raise NotImplementedError


class FrictionConstraint(Constraint):
    """Inner friction pyramid and normal-force bounds per contact (Raiola C_fc).

    |f_t,i| ≤ (√2/2) μ f_n on each tangent axis, f_min ≤ f_n ≤ f_max,i (the per-contact bound of
    the references when a behaviour sets one). The normal is world z for a
    point foot (flat ground) and the sole's z for a flat foot, whose wrench is in the sole frame.
    A contact that is not active carries no force at all.
    """

    name = "friction"

    def __init__(self, limits: ContactLimits) -> None:
        self.limits = limits
        self._cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        # The rows depend only on which feet are active and on the bounds: reuse them.
        upper = refs.normal_force_max
        limits = self.limits
        key = (refs.contact_active.tobytes(), upper.tobytes())
        key += (limits.friction, limits.normal_min, limits.normal_max)
        if key not in self._cache:
            if len(self._cache) > 64:
                self._cache.clear()
            if upper.size == 0:
                upper = np.full(len(robot.contacts), self.limits.normal_max)
            self._cache[key] = self._build(robot, refs.contact_active, upper)
        return self._cache[key]

    def _build(
        self, robot: RobotModel, contact_active: np.ndarray, upper: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        mu = np.sqrt(0.5) * self.limits.friction
        blocks_C, blocks_d = [], []
        for contact, rows, active, normal_max in zip(
            robot.contacts, robot.force_slices, contact_active, upper, strict=True
        ):
            col = robot.nv + rows.start
            if active:
                C, d = _rows(6, robot)
                for k, tangent in enumerate((0, 1)):
                    C[2 * k, col + tangent], C[2 * k, col + 2] = 1.0, -mu
                    C[2 * k + 1, col + tangent], C[2 * k + 1, col + 2] = -1.0, -mu
                C[4, col + 2], d[4] = -1.0, -self.limits.normal_min
                C[5, col + 2], d[5] = 1.0, normal_max
            else:
                n = contact.force_dim
                C, d = _rows(2 * n, robot)
                C[:n, col : col + n] = np.eye(n)
                C[n:, col : col + n] = -np.eye(n)
            blocks_C.append(C)
            blocks_d.append(d)
        C, d = np.concatenate(blocks_C), np.concatenate(blocks_d)
        C.flags.writeable = d.flags.writeable = False
        return C, d


def _soles_in_support(robot: RobotModel, contact_active: np.ndarray) -> list[tuple]:
    """(contact, column of its wrench's first entry in x) of each flat foot in support."""
    pairs = zip(robot.contacts, robot.force_slices, contact_active, strict=True)
    return [
        (contact, robot.nv + rows.start)
        for contact, rows, active in pairs
        if contact.kind == "flat" and active
    ]


INNER_COP_MARGIN = 0.15  # fraction of each half size of a sole


class CopConstraint(Constraint):
    """Centre of pressure inside the sole rectangle, for flat feet (Herzog §4.1).

    With the wrench (f, τ) in the sole frame at its centre, CoP = (−τ_y/f_z, τ_x/f_z), so
    |τ_y| ≤ L f_z and |τ_x| ≤ W f_z for half-length L and half-width W.
    """

    name = "cop"

    def __init__(self, margin: float = 0.0) -> None:
        """`margin`: the fraction of each half size kept free at the sole's edges."""
        self.scale = 1.0 - margin
        # The rows depend only on which feet are active: built once per contact set.
        self._rows = PerContactSet(self._build)

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        return self._rows.get(robot, refs.contact_active)

    def _build(
        self, robot: RobotModel, contact_active: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        blocks = []
        for contact, col in _soles_in_support(robot, contact_active):
            C, _ = _rows(4, robot)
            for k, (torque_axis, half) in enumerate(
                ((3, self.scale * contact.half_width), (4, self.scale * contact.half_length))
            ):
                C[2 * k, col + torque_axis], C[2 * k, col + 2] = 1.0, -half
                C[2 * k + 1, col + torque_axis], C[2 * k + 1, col + 2] = -1.0, -half
            blocks.append(C)
        C = np.concatenate(blocks) if blocks else np.zeros((0, robot.nx))
        d = np.zeros(len(C))
        C.flags.writeable = d.flags.writeable = False
        return C, d


class InnerCopConstraint(CopConstraint):
    """The CoP constraint with a safety margin: the CoP stays in the sole shrunk by
    INNER_COP_MARGIN. A sole asked for its CoP right on an edge starts to tip about that edge
    at the smallest model error (MuJoCo's soft contact gives a little there); the margin keeps
    the foot flat, which is what Herzog's CoP constraint is for (§5.3, Fig. 10–11)."""

    name = "cop_inner"

    def __init__(self) -> None:
        super().__init__(INNER_COP_MARGIN)


class SoleTorsionConstraint(Constraint):
    """Torsional friction of a flat sole: |τ_z| ≤ μ r f_z, r = (√2/2) min(L, W) (sole frame).

    The friction pyramid bounds a sole's tangential force but not its torque about the normal,
    so a sole with little load could be asked for tens of newton metres of yaw torque it cannot
    hold: it spins, and the ankle and hip yaw joints saturate fighting it. Caron et al. 2015
    give the exact bound, μ (L + W) f_z less terms for the tangential force and the CoP offset;
    this is its conservative inner part for a sole that also uses its friction and CoP.
    """

    name = "sole_torsion"

    def __init__(self, limits: ContactLimits) -> None:
        self.limits = limits
        self._cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        key = (refs.contact_active.tobytes(), self.limits.friction)
        if key not in self._cache:
            self._cache.clear()
            self._cache[key] = self._build(robot, refs.contact_active, self.limits.friction)
        return self._cache[key]

    @staticmethod
    def _build(
        robot: RobotModel, contact_active: np.ndarray, friction: float
    ) -> tuple[np.ndarray, np.ndarray]:
        blocks = []
        for contact, col in _soles_in_support(robot, contact_active):
            radius = np.sqrt(0.5) * min(contact.half_length, contact.half_width)
            C, _ = _rows(2, robot)
            C[0, col + 5], C[0, col + 2] = 1.0, -friction * radius
            C[1, col + 5], C[1, col + 2] = -1.0, -friction * radius
            blocks.append(C)
        C = np.concatenate(blocks) if blocks else np.zeros((0, robot.nx))
        d = np.zeros(len(C))
        C.flags.writeable = d.flags.writeable = False
        return C, d


class TorqueLimitConstraint(Constraint):
    """|τ| ≤ τ_max through τ = M_a q̈ + h_a − J_aᵀ F (Herzog eqs. 14, 16).

    The rows are kept from tick to tick and rewritten in place; the C and d handed out are
    read-only views, valid until the next `rows` call.
    """

    name = "torque_limits"

    def __init__(self, torque_limits: np.ndarray) -> None:
        self.torque_limits = np.asarray(torque_limits, dtype=float)
        self._robot: RobotModel | None = None

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        if robot is not self._robot:
            self._allocate(robot)
        # [M_a −J_aᵀ] x ≤ τ_max − h_a and −[M_a −J_aᵀ] x ≤ τ_max + h_a.
        self._tau_qdd[:] = robot.M[BASE_DOF:]
        np.negative(robot.Jc[:, BASE_DOF:].T, out=self._tau_force)
        np.negative(self._tau, out=self._minus_tau)
        h = robot.h[BASE_DOF:]
        np.subtract(self.torque_limits, h, out=self._d_tau)
        np.add(self.torque_limits, h, out=self._d_minus_tau)
        return self._views

    def _allocate(self, robot: RobotModel) -> None:
        self._robot = robot
        nv, na = robot.nv, robot.na
        C, d = np.empty((2 * na, robot.nx)), np.empty(2 * na)
        self._tau, self._minus_tau = C[:na], C[na:]
        self._tau_qdd, self._tau_force = C[:na, :nv], C[:na, nv:]
        self._d_tau, self._d_minus_tau = d[:na], d[na:]
        self._views = read_only(C), read_only(d)


class JointLimitConstraint(Constraint):
    """Joint-acceleration bounds that stop each joint at its position limit.

    Within the horizon T, q + q̇ T + ½ q̈ T² stays inside [q_min, q_max] (Hutter Table 6).
    """

    name = "joint_limits"

    def __init__(self, lower: np.ndarray, upper: np.ndarray, horizon: float = 0.05) -> None:
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        self.horizon = horizon

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        T = self.horizon
        q, dq = robot.joint_positions, robot.joint_velocities
        upper = 2.0 * (self.upper - q - dq * T) / T**2
        lower = 2.0 * (self.lower - q - dq * T) / T**2
        return _joint_bounds(robot.nx, robot.na), np.concatenate([upper, -lower])


@cache
def _joint_bounds(nx: int, na: int) -> np.ndarray:
    """Rows [I; −I] on the joint accelerations (read-only: shared by every tick)."""
    C = np.zeros((2 * na, nx))
    C[:na, BASE_DOF : BASE_DOF + na] = np.eye(na)
    C[na:, BASE_DOF : BASE_DOF + na] = -np.eye(na)
    C.flags.writeable = False
    return C
