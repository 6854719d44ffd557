"""The swing-sole task of Herzog 2016 Table 4: a flat foot out of support holds a pose.

For each flat foot the references leave out of support, J q̈ + J̇ v = a with the Cartesian PD of
§5.4 in the sole frame (pinocchio LOCAL, as the contact rows of flat feet):
a = [Rᵀ kp (p_ref − p) − kd v; kp log₃(Rᵀ R_ref) − kd ω]. References without sole targets
(`SoleReferences`) and feet in support give no rows.
"""

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.rows import JacobianRows, PerContactSet
from lab.controller.tasks.base import Task, TaskGains, TaskRows, no_task_rows


@dataclass
class SoleReferences(References):
    """References with a pose target per sole (world position, m, and rotation), read for the
    flat feet out of support."""

    sole_position: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    sole_rotation: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))


def _swinging_soles(robot: RobotModel, active: np.ndarray) -> JacobianRows:
    flat = np.array([contact.kind == "flat" for contact in robot.contacts])
    return JacobianRows.of(robot, flat & ~np.asarray(active, dtype=bool))


class SwingSoleTask(Task):
    """Flat feet out of support track their sole pose; the error is [p_ref − p (m, world);
    log₃(Rᵀ R_ref) (rad, sole frame)] per foot."""

    name = "swing_sole"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._rows = PerContactSet(_swinging_soles)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        if not isinstance(refs, SoleReferences) or not len(refs.sole_position):
            return no_task_rows(robot.nx)
        rows = self._rows.get(robot, refs.contact_active)
        if not len(rows.index):
            return no_task_rows(robot.nx)
        velocity = rows.write(robot) @ robot.v
        feet = [i for i in np.flatnonzero(~refs.contact_active) if robot.contacts[i].kind == "flat"]
        error = np.zeros(6 * len(feet))  # world position error, sole-frame rotation error
        local = np.zeros(6 * len(feet))  # the same in the sole frame, as J's rows
        for k, i in enumerate(feet):
            R = robot.contact_rotations[i]
            error[6 * k : 6 * k + 3] = refs.sole_position[i] - robot.contact_positions[i]
            error[6 * k + 3 : 6 * k + 6] = pin.log3(R.T @ refs.sole_rotation[i])
            local[6 * k : 6 * k + 3] = R.T @ error[6 * k : 6 * k + 3]
            local[6 * k + 3 : 6 * k + 6] = error[6 * k + 3 : 6 * k + 6]
        b = -robot.Jc_dot_v.take(rows.index) + self.gains.kp * local - self.gains.kd * velocity
        return TaskRows(rows.view, b, error)
