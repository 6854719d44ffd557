"""Load-distribution objectives of Hutter 2014 §4–5.1, as tasks usable at any level.

Over x = [q̈, F] (with the dynamics on top, as every hierarchy method keeps them):
- `torques` (τ min, W_τ = I, b_τ = 0): τ(x) = M_a q̈ + h_a − J_aᵀ F = 0 (Table 3, eqs. 44–45).
- `forces` (F min, W_F = I) already exists in tasks.py as the force regularization.
- `force_normal` (§5.1.5): W_F = blockdiag(tᵢᵀ), the tangential components of each support
  force in the local surface tangent plane → 0, so forces align with the surface normals. The
  weight α of the task is its gain weight.
- `force_interpolation` (§5.1.6): for a foot being loaded or unloaded, F_j = w F_j^opt with
  w ∈ [0, 1] from the behaviour; F^opt is the quasi-static minimum-force distribution over the
  feet in support (J_uᵀ F = h_u), the load distribution the foot would carry with full weight.
"""

import numpy as np

from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.references import References
from lab.controller.tasks import TASK_TYPES, Task
from lab.controller.walk_references import WalkReferences, surface_normals


def _no_rows(robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((0, robot.nx)), np.zeros(0)


class TorqueTask(Task):
    """Joint torques → 0 through τ(x): the actuation-efficiency objective (§5.1.1)."""

    name = "torques"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        a = slice(BASE_DOF, robot.nv)
        A = np.hstack([robot.M[a], -robot.Jc[:, a].T])
        self.error = np.zeros(0)
        return A, -robot.h[a]


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

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
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
        self.error = np.zeros(0)
        if not blocks:
            return _no_rows(robot)
        A = np.vstack(blocks)
        return A, np.zeros(len(A))


def quasi_static_forces(robot: RobotModel, active: np.ndarray) -> np.ndarray:
    """Minimum-norm forces of the active feet that carry the base: J_uᵀ F = h_u."""
    columns = np.concatenate(
        [np.arange(s.start, s.stop) for s, on in zip(robot.force_slices, active, strict=True) if on]
    )
    forces = np.zeros(robot.nf)
    base = robot.Jc[columns, :BASE_DOF].T
    forces[columns] = np.linalg.lstsq(base, robot.h[:BASE_DOF], rcond=None)[0]
    return forces


class ForceInterpolationTask(Task):
    """F_j = w F_j^opt for each foot whose interpolation weight w is set (§5.1.6)."""

    name = "force_interpolation"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        self.error = np.zeros(0)
        if not isinstance(refs, WalkReferences) or len(refs.force_weight) == 0:
            return _no_rows(robot)
        changing = np.isfinite(refs.force_weight) & refs.contact_active
        if not np.any(changing):
            return _no_rows(robot)
        optimal = quasi_static_forces(robot, refs.contact_active)
        A_rows, b_rows = [], []
        for rows, w, on in zip(robot.force_slices, refs.force_weight, changing, strict=True):
            if not on:
                continue
            A = np.zeros((rows.stop - rows.start, robot.nx))
            A[:, robot.nv + rows.start : robot.nv + rows.stop] = np.eye(rows.stop - rows.start)
            A_rows.append(A)
            b_rows.append(w * optimal[rows])
        return np.vstack(A_rows), np.concatenate(b_rows)


for _task in (TorqueTask, ForceNormalTask, ForceInterpolationTask):
    TASK_TYPES[_task.name] = _task
