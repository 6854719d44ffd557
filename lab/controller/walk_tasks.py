"""Motion tasks of the static-walk experiments (Hutter 2014 §5.1): swing feet and planar CoM.

- `swing_feet`: each point foot out of support tracks the behaviour's swing trajectory,
  J_i q̈ + J̇_i v = a_ref + kp (p_ref − p) + kd (v_ref − v), world axes. Flat feet and references
  without foot trajectories give no rows.
- `com_xy`: the horizontal CoM alone (Table 6, P3), so that body height can sit at another
  priority (`base_height`).
- `moving_posture`: Raiola's postural task eq. 9 with a moving reference,
  q̈_a = kp (q_d − q_a) + kd (q̇_d − q̇_a), q̇_d from the walking references (eqs. 30–31), zero
  for references without one. A swinging leg's joints are left to `swing_feet`, which fixes
  them at a higher priority: posture rows on them only steer the base's acceleration (under S3,
  ANYmal's 0.5 m/s trot ran at 0.62 m/s with ±0.25 m/s of lateral sway; without them at
  0.525 m/s and ±0.06 m/s). A leg's rows are scaled by `posture_weight` (its load ramp), so they
  fade in after touchdown and out before lift-off instead of switching: at touchdown the leg's
  joints still move at the swing's speed, and a row switching on with kd (q̇_d − q̇) stepped
  ANYmal's stance normal forces by 207 N in one tick.
"""

import numpy as np

from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.references import References
from lab.controller.tasks import TASK_TYPES, ComTask, Task, TaskGains
from lab.controller.walk_references import WalkReferences


class SwingFeetTask(Task):
    name = "swing_feet"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        swinging = _swinging(robot, refs)
        if not swinging:
            self.error = np.zeros(0)
            return np.zeros((0, robot.nx)), np.zeros(0)
        idx = np.concatenate(
            [np.arange(robot.force_slices[i].start, robot.force_slices[i].stop) for i in swinging]
        )
        J = robot.Jc[idx]
        e = (refs.foot_position[swinging] - robot.contact_positions[swinging]).ravel()
        de = refs.foot_velocity[swinging].ravel() - J @ robot.v
        A = np.zeros((len(idx), robot.nx))
        A[:, : robot.nv] = J
        b = (
            refs.foot_acceleration[swinging].ravel()
            + self.gains.kp * e
            + self.gains.kd * de
            - robot.Jc_dot_v[idx]
        )
        self.error = e
        return A, b


class ComXYTask(ComTask):
    name = "com_xy"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        A, b = super().rows(robot, refs)
        self.error = self.error[:2]
        return A[:2], b[:2]


def leg_joints(robot: RobotModel) -> list[np.ndarray]:
    """Actuated-joint indices of each contact's leg: the joints that move the contact point."""
    return [
        np.flatnonzero(np.any(np.abs(robot.Jc[s, BASE_DOF:]) > 1e-9, axis=0))
        for s in robot.force_slices
    ]


def _swinging(robot: RobotModel, refs: References) -> list[int]:
    """Point feet out of contact that have a swing trajectory (the `swing_feet` task's feet)."""
    if not isinstance(refs, WalkReferences) or not len(refs.foot_position):
        return []
    return [
        i
        for i, (contact, active) in enumerate(zip(robot.contacts, refs.contact_active, strict=True))
        if not active and contact.kind == "point"
    ]


class MovingPostureTask(Task):
    name = "moving_posture"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._legs: list[np.ndarray] | None = None

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        if self._legs is None:
            self._legs = leg_joints(robot)
        reference_velocity = np.zeros(robot.na)
        weight = np.ones(robot.na)
        if isinstance(refs, WalkReferences):
            if len(refs.posture_velocity) == robot.na:
                reference_velocity = refs.posture_velocity
            if len(refs.posture_weight) == len(self._legs):
                for leg, w in zip(self._legs, refs.posture_weight, strict=True):
                    weight[leg] = w
        for i in _swinging(robot, refs):
            weight[self._legs[i]] = 0.0
        joints = np.flatnonzero(weight > 0.0)
        w = weight[joints]
        e = (refs.posture - robot.q[7:])[joints]
        self.error = e
        A = np.zeros((len(joints), robot.nx))
        A[np.arange(len(joints)), BASE_DOF + joints] = w
        de = reference_velocity[joints] - robot.v[BASE_DOF + joints]
        return A, w * (self.gains.kp * e + self.gains.kd * de)


for _task in (SwingFeetTask, ComXYTask, MovingPostureTask):
    TASK_TYPES[_task.name] = _task
