"""Centre-of-mass tasks: the CoM in 3-D, its horizontal part alone (Hutter 2014 Table 6), and
on two point feet its horizontal parts along and across the foot line (Kim 2016 Fig. 6c)."""

import numpy as np

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.tasks.base import Task, TaskRows, no_task_rows

Z = np.array([0.0, 0.0, 1.0])


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


def foot_line(robot: RobotModel, refs: References) -> np.ndarray | None:
    """The horizontal unit vector (world) from the first to the second point foot in support,
    or None with fewer than two point feet in support (or two over each other)."""
    feet = np.flatnonzero(
        refs.contact_active & np.array([c.kind == "point" for c in robot.contacts])
    )
    if len(feet) < 2:
        return None
    line = robot.contact_positions[feet[1]] - robot.contact_positions[feet[0]]
    line[2] = 0.0
    length = np.linalg.norm(line)
    return line / length if length > 1e-6 else None


class ComAlongFeetTask(ComTask):
    """The CoM's horizontal position along the line between two point feet in support, one
    row: Kim 2016's soft horizontal CoM (Fig. 6c, Table I's COM_x), which on Hume in its
    planarizer runs along the feet. With fewer than two point feet in support, no rows."""

    name = "com_along_feet"

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        line = foot_line(robot, refs)
        if line is None:
            return no_task_rows(robot.nx)
        return _component(super().rows(robot, refs), line)


class ComAcrossFeetTask(ComTask):
    """The CoM's horizontal position across the line between two point feet in support, one
    row: the inner loop of the foot-line balance (`behaviours/line_balance.py`), which needs it
    stiff, where Hume's planarizer held it. With fewer than two point feet in support, no
    rows."""

    name = "com_across_feet"

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        line = foot_line(robot, refs)
        if line is None:
            return no_task_rows(robot.nx)
        return _component(super().rows(robot, refs), np.cross(line, Z))


def _component(rows: TaskRows, direction: np.ndarray) -> TaskRows:
    """The one row of 3-D CoM rows along `direction` (unit, world)."""
    A, b, e = rows
    return TaskRows((direction @ A)[None], np.array([direction @ b]), np.array([direction @ e]))
