"""What every task is: a named producer of equality rows `A x = b` over x = [q̈, F], with PD gains
and a weight, and the tracking error it measured while building them.

A motion task asks an operational-space acceleration `J q̈ + J̇v = a_des` with the PD law
`a_des = a_ref + kp e + kd ė` (Raiola eqs. 7–9); a force task asks F directly. Each task class
declares in `GAINS` which of kp, kd and weight it reads (the others keep their defaults and the
UI hides them).

A task also declares what the controller must do for it beyond building its rows, so that no
controller asks for a task by name: whether it reads the sensors (`READS_SENSING`, `sense`),
and whether it holds inputs in Python that the native kernel needs each tick (`KERNEL_INPUTS`,
`to_kernel`, `from_kernel`; the momentum task's LQR schedule is asked from inside the kernel's
tick on the rare ticks that change its gain).
"""

from collections.abc import Callable
from typing import ClassVar, NamedTuple, Protocol

import numpy as np

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.rows import FixedRows, no_rows, zeros

# One record for the controller, the protocol and the UI; re-exported to the task modules.
from lab.protocol import TaskGains as TaskGains

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


# What the momentum schedule answers the kernel (MomentumTask._schedule_tick): K_h, and to hold
# its target at, the contact flags, the arms and the blend (from, to, steps made, length) or None.
KernelSchedule = tuple[
    np.ndarray,
    np.ndarray | None,
    np.ndarray | None,
    tuple[np.ndarray, np.ndarray, int, int] | None,
]


class KernelInputs(Protocol):
    """The native kernel's setters of what tasks hold in Python (lab._kernel.Kernel)."""

    def set_momentum_gain(self, gain: np.ndarray) -> None:
        """The momentum task's K_h (6 × 9)."""

    def set_momentum_schedule(
        self, schedule: Callable[[int], KernelSchedule] | None, arm_tolerance: float
    ) -> None:
        """The momentum task's LQR schedule, asked inside a tick where no held K_h holds, with
        the blend steps made since the last ask: it returns K_h and the contact flags and arms
        to hold its target at, with the blend to step meanwhile (None, None, None: not held)."""

    def take_momentum_blend_steps(self) -> int:
        """The blend steps the kernel made since the schedule was last asked, from zero again."""

    def release_momentum_gain(self) -> None:
        """The next tick asks the momentum schedule again."""

    def set_internal_force(self, reference: float, source: str) -> None:
        """The internal-force task's F_int,ref (N) and sensed source."""


class KernelReport(Protocol):
    """What a native tick reports of the values tasks show (lab._kernel.TickOutcome)."""

    internal_force_sensed: np.ndarray
    internal_force_command: np.ndarray


class Task:
    """Base class: a named producer of equality rows. Subclasses set `name`, `GAINS` and
    implement `rows`; a task that needs more of the controller declares it (module
    docstring)."""

    name: str = ""
    GAINS: ClassVar[tuple[str, ...]] = ALL_GAINS  # the gains `rows` reads (weight always)
    # The rows read what `sense` hands over: the session measures the foot forces only then.
    READS_SENSING: ClassVar[bool] = False
    # The task holds inputs in Python that `to_kernel` hands the native kernel before each of
    # its ticks, and takes back what the tick computed of them with `from_kernel`.
    KERNEL_INPUTS: ClassVar[bool] = False

    def __init__(self, gains: TaskGains | None = None) -> None:
        self.gains = gains or TaskGains()
        self._fixed = FixedRows()

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        """This tick's rows at the state of the last `robot.update`, tracking `refs`."""
        raise NotImplementedError

    def sense(self, foot_forces: np.ndarray, applied_torques: np.ndarray) -> None:
        """What the sensors measured over the last step (a READS_SENSING task keeps it): the
        terrain's force on each foot (n_contacts × 3, N, world) and the joint torques applied
        (N m)."""

    def to_kernel(self, kernel: KernelInputs, robot: RobotModel, refs: References) -> None:
        """Hand `kernel` this tick's inputs held in Python (a KERNEL_INPUTS task), at the state
        of the last `robot.update`."""

    def from_kernel(self, report: KernelReport) -> None:
        """Take what the native tick computed of the values this task shows (a KERNEL_INPUTS
        task)."""

    def _matrix(self, robot: RobotModel, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The task's n rows over x (zero until written) and a read-only view to hand out, for
        a task with a fixed number of rows: allocated on its first tick, then reused."""
        return self._fixed.get(robot, n)
