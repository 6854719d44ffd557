"""What every task is: a named producer of equality rows `A x = b` over x = [q̈, F], with PD gains
and a weight, and the tracking error it measured while building them.

A motion task asks an operational-space acceleration `J q̈ + J̇v = a_des` with the PD law
`a_des = a_ref + kp e + kd ė` (Raiola eqs. 7–9); a force task asks F directly. Each task class
declares in `GAINS` which of kp, kd and weight it reads (the others keep their defaults and the
UI hides them).
"""

from typing import ClassVar, NamedTuple

import numpy as np

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.rows import FixedRows, no_rows, zeros
from lab.protocol import TaskGains  # one record for the controller, the protocol and the UI

ALL_GAINS = ("kp", "kd", "weight")


class TaskRows(NamedTuple):
    """A task's rows this tick: `A x = b` over x = [q̈, F], and the tracking error it measured
    (in the task's own units and frame; empty for a task that tracks nothing)."""

    A: np.ndarray
    b: np.ndarray
    error: np.ndarray


def no_task_rows(nx: int) -> TaskRows:
    """No rows and no error, over x of size nx."""
    return TaskRows(*no_rows(nx), zeros(0))


class Task:
    """Base class: a named producer of equality rows. Subclasses set `name`, `GAINS` and
    implement `rows`."""

    name: str = ""
    GAINS: ClassVar[tuple[str, ...]] = ALL_GAINS  # the gains `rows` reads (weight always)

    def __init__(self, gains: TaskGains | None = None) -> None:
        self.gains = gains or TaskGains()
        self._fixed = FixedRows()

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        """This tick's rows at the state of the last `robot.update`, tracking `refs`."""
        raise NotImplementedError

    def _matrix(self, robot: RobotModel, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The task's n rows over x (zero until written) and a read-only view to hand out, for
        a task with a fixed number of rows: allocated on its first tick, then reused."""
        return self._fixed.get(robot, n)
