"""The swing-feet task of the walking stacks (Raiola S3, Hutter 2014 §5.1): each point foot out of
support tracks the behaviour's swing trajectory.

J_i q̈ + J̇_i v = a_ref + kp (p_ref − p) + kd (v_ref − v), world axes. Flat feet and references
without foot trajectories give no rows.
"""

from dataclasses import dataclass

import numpy as np

from lab.controller.model import RobotModel
from lab.controller.references import References, WalkReferences
from lab.controller.rows import JacobianRows, PerContactSet
from lab.controller.tasks.base import Task, TaskGains, TaskRows, no_task_rows


def has_swing(refs: References) -> bool:
    """Whether the references give the feet swing trajectories (walking references do)."""
    walk = refs.walking
    return walk is not None and len(walk.foot_position) > 0


def swinging(robot: RobotModel, active: np.ndarray) -> np.ndarray:
    """Flags of the point feet out of contact: the `swing_feet` task's feet when the references
    have swing trajectories."""
    point = np.array([contact.kind == "point" for contact in robot.contacts])
    flags: np.ndarray = point & ~np.asarray(active, dtype=bool)
    return flags


def _not_tracked(refs: WalkReferences) -> np.ndarray:
    """The flags `SwingRows.of` takes: the feet out of contact, or those the references name."""
    if len(refs.swing_tracked) == len(refs.contact_active):
        return ~refs.swing_tracked
    return refs.contact_active


@dataclass(frozen=True)
class SwingRows:
    """The swinging point feet of one contact set and the task's rows for them."""

    coords: np.ndarray  # their entries in the flattened (n_contacts, 3) per-foot arrays
    jacobian: JacobianRows

    @classmethod
    def of(cls, robot: RobotModel, active: np.ndarray) -> "SwingRows":
        """The rows of the point feet that `active` leaves out of support."""
        feet = swinging(robot, active)
        coords = (3 * np.flatnonzero(feet)[:, None] + np.arange(3)).ravel()
        return cls(coords, JacobianRows.of(robot, feet))


class SwingFeetTask(Task):
    """Swinging point feet track their swing references; the error is p_ref − p (m, world)."""

    name = "swing_feet"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._swing = PerContactSet(SwingRows.of)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        walk = refs.walking
        if walk is None or not len(walk.foot_position):
            return no_task_rows(robot.nx)
        swing = self._swing.get(robot, _not_tracked(walk))
        if not len(swing.coords):
            return no_task_rows(robot.nx)
        feet, jacobian = swing.coords, swing.jacobian
        e = walk.foot_position.take(feet) - robot.contact_positions.take(feet)
        de = walk.foot_velocity.take(feet) - jacobian.write(robot).dot(robot.v)
        b = (
            walk.foot_acceleration.take(feet)
            + self.gains.kp * e
            + self.gains.kd * de
            - robot.Jc_dot_v[jacobian.index]
        )
        return TaskRows(jacobian.view, b, e)
