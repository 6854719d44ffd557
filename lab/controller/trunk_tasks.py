"""Trunk tasks of Hutter's dynamic-trot hierarchy (Hutter 2014 Table 7): body roll-pitch, turning
rate, planar body velocity. (Body height is `base_height`; the support is `contact`.)

They register themselves in `TASK_TYPES`; `tasks.py` imports this module to complete it.
"""

import numpy as np
import pinocchio as pin

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.tasks import TASK_TYPES, Task, selection


class RollPitchTask(Task):
    """Body roll and pitch (base-frame x, y rows of the angular acceleration, Hutter Table 7 P3):
    ω̇_b,xy = kp e_b,xy + kd (ω_ref − ω)_b,xy with e = log(R_ref Rᵀ) expressed in the base frame.

    The free-flyer angular acceleration is already in the base frame, so the rows select it.
    """

    name = "roll_pitch"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        R = robot.base_rotation
        e = R.T @ pin.log3(refs.base_rotation @ R.T)
        de = R.T @ refs.base_angular_velocity - robot.v[3:6]
        self.error = e[:2]
        return selection(robot.nx, 3, 5), self.gains.kp * e[:2] + self.gains.kd * de[:2]


class YawRateTask(Task):
    """Turning rate about the world vertical (Hutter Table 7 P4): ω̇_z = kd (ψ̇_ref − ψ̇).

    ω_world = R ω_b and Ṙ ω_b = R (ω_b × ω_b) = 0, so the row is the last row of R.
    """

    name = "yaw_rate"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        R = robot.base_rotation
        e = refs.base_angular_velocity[2] - robot.base_angular_velocity_world[2]
        A, view = self._matrix(robot, 1)
        A[0, 3:6] = R[2]
        self.error = np.array([e])
        return view, np.array([self.gains.kd * e])


class PlanarVelocityTask(Task):
    """Body velocity along the base x and y axes (Hutter Table 7 P5): v̇_b,xy = kd (v_ref − v)_b,xy.

    The free-flyer linear velocity is in the base frame and v̇ is its derivative, so the rows
    select it; the reference is `refs.base_linear_velocity` (world) seen from the base.
    """

    name = "base_velocity"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        e = robot.base_rotation.T @ refs.base_linear_velocity - robot.v[:3]
        self.error = e[:2]
        return selection(robot.nx, 0, 2), self.gains.kd * e[:2]


TASK_TYPES.update({t.name: t for t in (RollPitchTask, YawRateTask, PlanarVelocityTask)})
