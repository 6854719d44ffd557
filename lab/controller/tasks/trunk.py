"""Trunk tasks: base orientation and height (Raiola S3), and the trunk tasks of Hutter's
dynamic-trot hierarchy (Hutter 2014 Table 7): body roll-pitch, turning rate, planar body
velocity. (Hutter's body height is `base_height`; the support is `contact`.)
"""

import numpy as np
import pinocchio as pin

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.rows import selection
from lab.controller.tasks.base import Task, TaskRows


class BaseOrientationTask(Task):
    """Base angular acceleration in world axes tracks ω̇ = kp log(R_ref Rᵀ) + kd (ω_ref − ω).
    The error is log(R_ref Rᵀ) (rad, world axes).

    The free-flyer angular acceleration is in the base frame, so the rows are simply R.
    """

    name = "base_orientation"

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        R = robot.base_rotation
        e = pin.log3(refs.base_rotation.dot(R.T))
        de = refs.base_angular_velocity - R.dot(robot.base_angular_velocity)  # ω, world axes
        A, view = self._matrix(robot, 3)
        A[:, 3:6] = R
        return TaskRows(view, self.gains.kp * e + self.gains.kd * de, e)


class BaseHeightTask(Task):
    """Vertical base acceleration tracks the base-height reference (error in m, world z).

    World base acceleration is d/dt(R v_b) = R (v̇_b + ω_b × v_b); only its z row is used.
    """

    name = "base_height"

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        R = robot.base_rotation
        v_lin, w = robot.base_linear_velocity, robot.base_angular_velocity
        e = refs.base_height - robot.base_position[2]
        de = -(R @ v_lin)[2]
        A, view = self._matrix(robot, 1)
        A[0, :3] = R[2]
        drift = (R @ np.cross(w, v_lin))[2]
        b = np.array([self.gains.kp * e + self.gains.kd * de - drift])
        return TaskRows(view, b, np.array([e]))


class RollPitchTask(Task):
    """Body roll and pitch (base-frame x, y rows of the angular acceleration, Hutter Table 7 P3):
    ω̇_b,xy = kp e_b,xy + kd (ω_ref − ω)_b,xy with e = log(R_ref Rᵀ) expressed in the base frame
    (the error, rad).

    The free-flyer angular acceleration is already in the base frame, so the rows select it.
    """

    name = "roll_pitch"

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        R = robot.base_rotation
        e = R.T @ pin.log3(refs.base_rotation @ R.T)
        de = R.T @ refs.base_angular_velocity - robot.base_angular_velocity
        b = self.gains.kp * e[:2] + self.gains.kd * de[:2]
        return TaskRows(selection(robot.nx, 3, 5), b, e[:2])


class YawRateTask(Task):
    """Turning rate about the world vertical (Hutter Table 7 P4): ω̇_z = kd (ψ̇_ref − ψ̇); the
    error is ψ̇_ref − ψ̇ (rad/s).

    ω_world = R ω_b and Ṙ ω_b = R (ω_b × ω_b) = 0, so the row is the last row of R.
    """

    name = "yaw_rate"
    GAINS = ("kd", "weight")

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        R = robot.base_rotation
        e = refs.base_angular_velocity[2] - robot.base_angular_velocity_world[2]
        A, view = self._matrix(robot, 1)
        A[0, 3:6] = R[2]
        return TaskRows(view, np.array([self.gains.kd * e]), np.array([e]))


class PlanarVelocityTask(Task):
    """Body velocity along the base x and y axes (Hutter Table 7 P5): v̇_b,xy = kd (v_ref − v)_b,xy,
    the error (m/s, base axes).

    The free-flyer linear velocity is in the base frame and v̇ is its derivative, so the rows
    select it; the reference is `refs.base_linear_velocity` (world) seen from the base.
    """

    name = "base_velocity"
    GAINS = ("kd", "weight")

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        e = robot.base_rotation.T @ refs.base_linear_velocity - robot.base_linear_velocity
        return TaskRows(selection(robot.nx, 0, 2), self.gains.kd * e[:2], e[:2])
