"""The swing-sole task of Herzog 2016 Table 4: a flat foot out of support holds a pose.

For each flat foot the references leave out of support, J q̈ + J̇ v = a with the Cartesian PD of
§5.4 in the sole frame (pinocchio LOCAL, as the contact rows of flat feet):
a = [Rᵀ kp (p_ref − p) − kd v; kp log₃(Rᵀ R_ref) − kd ω]. References without sole targets
(`References.soles`) and feet in support give no rows.

`swing_leg` is the same foot's motion in joint space, as Herzog's leg-swing experiment does it
(§5.4, Fig. 11): the joints of a leg the references mark `leg_swinging` track a trajectory,
q̈ = q̈_ref + kp (q_ref − q) + kd (q̇_ref − q̇), and `swing_sole` leaves that foot alone.
"""

import numpy as np
import pinocchio as pin

from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.references import References
from lab.controller.rows import JacobianRows, PerContactSet
from lab.controller.tasks.base import Task, TaskGains, TaskRows, no_task_rows
from lab.controller.tasks.posture import leg_joints


def leg_swinging(refs: References) -> np.ndarray | None:
    """Which contacts' legs swing in joint space (None for references without them)."""
    soles = refs.soles
    if soles is None or not len(soles.leg_swinging):
        return None
    swinging: np.ndarray = soles.leg_swinging & ~refs.contact_active
    return swinging


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
        soles = refs.soles
        if soles is None or not len(soles.sole_position):
            return no_task_rows(robot.nx)
        held = refs.contact_active  # feet in support, or whose leg swings in joint space
        swinging = leg_swinging(refs)
        if swinging is not None:
            held = held | swinging
        rows = self._rows.get(robot, held)
        if not len(rows.index):
            return no_task_rows(robot.nx)
        velocity = rows.write(robot) @ robot.v
        feet = [i for i in np.flatnonzero(~held) if robot.contacts[i].kind == "flat"]
        error = np.zeros(6 * len(feet))  # world position error, sole-frame rotation error
        local = np.zeros(6 * len(feet))  # the same in the sole frame, as J's rows
        for k, i in enumerate(feet):
            R = robot.contact_rotations[i]
            error[6 * k : 6 * k + 3] = soles.sole_position[i] - robot.contact_positions[i]
            error[6 * k + 3 : 6 * k + 6] = pin.log3(R.T @ soles.sole_rotation[i])
            local[6 * k : 6 * k + 3] = R.T @ error[6 * k : 6 * k + 3]
            local[6 * k + 3 : 6 * k + 6] = error[6 * k + 3 : 6 * k + 6]
        b = -robot.Jc_dot_v.take(rows.index) + self.gains.kp * local - self.gains.kd * velocity
        return TaskRows(rows.view, b, error)


class SwingLegTask(Task):
    """The joints of each leg the references mark swinging track their trajectory (module
    docstring); the error is q_ref − q of those joints (rad)."""

    name = "swing_leg"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._legs: list[np.ndarray] | None = None

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        swinging, soles = leg_swinging(refs), refs.soles
        if swinging is None or soles is None or not swinging.any():
            return no_task_rows(robot.nx)
        if self._legs is None:
            self._legs = leg_joints(robot)
        joints = np.concatenate([self._legs[i] for i in np.flatnonzero(swinging)])
        A = np.zeros((len(joints), robot.nx))
        A[np.arange(len(joints)), BASE_DOF + joints] = 1.0
        e = soles.leg_position[joints] - robot.joint_positions[joints]
        de = soles.leg_velocity[joints] - robot.joint_velocities[joints]
        b = soles.leg_acceleration[joints] + self.gains.kp * e + self.gains.kd * de
        return TaskRows(A, b, e)
