"""Motion tasks of the static-walk experiments (Hutter 2014 §5.1): swing feet and planar CoM.

- `swing_feet`: each point foot out of support tracks the behaviour's swing trajectory,
  J_i q̈ + J̇_i v = a_ref + kp (p_ref − p) + kd (v_ref − v), world axes. Flat feet and references
  without foot trajectories give no rows.
- `com_xy`: the horizontal CoM alone (Table 6, P3), so that body height can sit at another
  priority (`base_height`).
"""

import numpy as np

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.tasks import TASK_TYPES, ComTask, Task
from lab.controller.walk_references import WalkReferences


class SwingFeetTask(Task):
    name = "swing_feet"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        swinging = []
        if isinstance(refs, WalkReferences) and len(refs.foot_position):
            swinging = [
                i
                for i, (contact, active) in enumerate(
                    zip(robot.contacts, refs.contact_active, strict=True)
                )
                if not active and contact.kind == "point"
            ]
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


for _task in (SwingFeetTask, ComXYTask):
    TASK_TYPES[_task.name] = _task
