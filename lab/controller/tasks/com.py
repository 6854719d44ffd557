"""Centre-of-mass tasks: the CoM in 3-D, and its horizontal part alone (Hutter 2014 Table 6)."""

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.tasks.base import Task, TaskRows


class ComTask(Task):
    """CoM acceleration J_com q̈ + J̇_com v = kp (c_ref − c) + kd (ċ_ref − ċ), world axes; the
    error is c_ref − c (m)."""

    name = "com"

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        e = refs.com - robot.com
        de = refs.com_velocity - robot.com_velocity
        A, view = self._matrix(robot, 3)
        A[:, : robot.nv] = robot.Jcom
        return TaskRows(view, self.gains.kp * e + self.gains.kd * de - robot.com_drift, e)


class ComXYTask(ComTask):
    """The horizontal CoM alone (Hutter 2014 Table 6, P3), so that body height can sit at
    another priority (`base_height`): the x, y rows of `com`."""

    name = "com_xy"

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        A, b, e = super().rows(robot, refs)
        return TaskRows(A[:2], b[:2], e[:2])
