"""Load-distribution objectives of Hutter 2014 §4–5.1, as tasks usable at any level.

Over x = [q̈, F] (with the dynamics on top, as every hierarchy method keeps them):
- `forces` (F min, W_F = I): the force regularization, F → 0.
- `sole_forces`: `forces` with each flat sole's roll and pitch moments in its half-sizes.
- `torques` (τ min, W_τ = I, b_τ = 0): τ(x) = M_a q̈ + h_a − J_aᵀ F = 0 (Table 3, eqs. 44–45).
- `force_normal` (§5.1.5): W_F = blockdiag(tᵢᵀ), the tangential components of each support
  force in the local surface tangent plane → 0, so forces align with the surface normals. The
  weight α of the task is its gain weight.
- `internal_wrench`: the part of the support wrenches the base does not feel → 0 (below).
- `force_interpolation` (§5.1.6): for a foot being loaded or unloaded, F_j = w F_j^opt with
  w ∈ [0, 1] from the behaviour; F^opt is the quasi-static minimum-force distribution over the
  feet in support (J_uᵀ F = h_u), the load distribution the foot would carry with full weight.

None of them tracks a reference: they have no error and read only their weight.
"""

import numpy as np

from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.references import References, surface_normals
from lab.controller.rows import contact_rows, selection, zeros
from lab.controller.tasks.base import Task, TaskRows, no_task_rows


class ForceTask(Task):
    """Contact-force regularization: F → 0 (the minimum-force load distribution, W_F = I)."""

    name = "forces"
    GAINS = ("weight",)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        return TaskRows(selection(robot.nx, robot.nv, robot.nx), zeros(robot.nf), zeros(0))


class SoleForceTask(Task):
    """F → 0 with each flat sole's roll and pitch moments priced in the sole's own half-sizes:
    τ_x / W and τ_y / L (sole frame), the sole's load times its CoP offset in half-sizes.

    Under `forces` (W_F = I) a newton and a newton metre cost alike; with soles a distance 2d
    apart, the minimum-norm split of a roll moment puts a share 1/(1 + d²) of it in the ankles
    (99 % for d = 0.1 m) rather than in load moved from one sole to the other. A lateral push then
    drives both soles' CoPs to their edges, where the CoP rows bind. Priced per sole size, the
    moment goes first to the load difference, which the soles can give."""

    name = "sole_forces"
    GAINS = ("weight",)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        A, view = self._matrix(robot, robot.nf)
        A[:, robot.nv :] = np.eye(robot.nf)
        for contact, rows in zip(robot.contacts, robot.force_slices, strict=True):
            if contact.kind == "flat":
                A[rows.start + 3, robot.nv + rows.start + 3] = 1.0 / contact.half_width
                A[rows.start + 4, robot.nv + rows.start + 4] = 1.0 / contact.half_length
        return TaskRows(view, zeros(robot.nf), zeros(0))


class InternalWrenchTask(Task):
    """The support wrenches' internal part → 0: (I − G⁺G) F = 0 with G = J_uᵀ over the forces of
    the feet in support (G F is the wrench the base feels; G's null space is what the feet exert
    on each other: a squeeze, opposite roll or yaw torques). The momentum does not see it, so
    Herzog's regularizer on the whole F at 10⁻⁴ is all that holds it; once a CoP constraint
    binds, the solution then ran to the corners of the soles' CoP, torsion and friction bounds
    (a lateral squeeze saturating Talos's hip roll) and the soles rocked on their edges. This
    prices that part alone, leaving the load the momentum asks to the regularizer (the
    `herzog_squat_cop` scenario adds it to Table 2; docs/controller.md)."""

    name = "internal_wrench"
    GAINS = ("weight",)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        columns = contact_rows(robot, refs.contact_active)
        if not len(columns):
            return no_task_rows(robot.nx)
        base = robot.Jc[columns, :BASE_DOF].T
        A = np.zeros((len(columns), robot.nx))
        A[:, robot.nv + columns] = np.eye(len(columns)) - np.linalg.pinv(base) @ base
        return TaskRows(A, np.zeros(len(columns)), zeros(0))


class TorqueTask(Task):
    """Joint torques → 0 through τ(x): the actuation-efficiency objective (§5.1.1)."""

    name = "torques"
    GAINS = ("weight",)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        a = slice(BASE_DOF, robot.nv)
        A, view = self._matrix(robot, robot.na)
        A[:, : robot.nv] = robot.M[a]
        np.negative(robot.Jc[:, a].T, out=A[:, robot.nv :])
        return TaskRows(view, -robot.h[a], zeros(0))


def tangent_basis(normal: np.ndarray) -> np.ndarray:
    """Two unit tangents (rows) orthogonal to `normal` and to each other."""
    n = normal / np.linalg.norm(normal)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = np.cross(n, helper)
    t1 /= np.linalg.norm(t1)
    return np.vstack([t1, np.cross(n, t1)])


class ForceNormalTask(Task):
    """Tangential support forces in the local surface tangent plane → 0 (§5.1.5)."""

    name = "force_normal"
    GAINS = ("weight",)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        normals = surface_normals(refs, len(robot.contacts))
        blocks = []
        for i, (contact, rows, active) in enumerate(
            zip(robot.contacts, robot.force_slices, refs.contact_active, strict=True)
        ):
            if not active:
                continue
            tangents = tangent_basis(normals[i])
            if contact.kind == "flat":  # the wrench is in the sole frame
                tangents = tangents @ robot.contact_rotations[i]
            A = np.zeros((2, robot.nx))
            A[:, robot.nv + rows.start : robot.nv + rows.start + 3] = tangents
            blocks.append(A)
        if not blocks:
            return no_task_rows(robot.nx)
        A = np.vstack(blocks)
        return TaskRows(A, np.zeros(len(A)), zeros(0))


def quasi_static_forces(robot: RobotModel, active: np.ndarray) -> np.ndarray:
    """Minimum-norm forces (N, the layout of F) of the active feet that carry the base:
    J_uᵀ F = h_u."""
    columns = contact_rows(robot, active)
    forces = np.zeros(robot.nf)
    base = robot.Jc[columns, :BASE_DOF].T
    forces[columns] = np.linalg.lstsq(base, robot.h[:BASE_DOF], rcond=None)[0]
    return forces


class ForceInterpolationTask(Task):
    """F_j = w F_j^opt for each foot whose interpolation weight w is set (§5.1.6)."""

    name = "force_interpolation"
    GAINS = ("weight",)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        walk = refs.walking
        if walk is None or len(walk.force_weight) == 0:
            return no_task_rows(robot.nx)
        changing = np.isfinite(walk.force_weight) & refs.contact_active
        if not np.any(changing):
            return no_task_rows(robot.nx)
        optimal = quasi_static_forces(robot, refs.contact_active)
        index = contact_rows(robot, changing)
        A = np.zeros((len(index), robot.nx))
        A[np.arange(len(index)), robot.nv + index] = 1.0
        w = np.repeat(walk.force_weight[changing], robot.force_dims[changing])
        return TaskRows(A, w * optimal[index], zeros(0))
