"""Row caches shared by every task and constraint: what a tick would otherwise allocate again.

Rows are built every tick, so a task or constraint keeps its matrix from tick to tick and
rewrites in place only the entries that move; what depends only on which contacts are active
(index arrays, row counts) is built once per contact set (`PerContactSet`). Matrices handed out
are read-only views, valid until their owner's next `rows` call. Small products use
`ndarray.dot`, which costs half the call overhead of `@` (same result).
"""

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Generic, TypeVar

import numpy as np

from lab.controller.model import RobotModel


@cache
def selection(nx: int, start: int, stop: int) -> np.ndarray:
    """Rows selecting x[start:stop] (read-only: shared by every tick)."""
    A = np.zeros((stop - start, nx))
    A[:, start:stop] = np.eye(stop - start)
    A.flags.writeable = False
    return A


@cache
def zeros(n: int) -> np.ndarray:
    """n zeros (read-only: shared by every tick)."""
    z = np.zeros(n)
    z.flags.writeable = False
    return z


def read_only(a: np.ndarray) -> np.ndarray:
    """A view of `a` that its readers cannot write (the owner still writes `a` in place)."""
    view = a.view()
    view.flags.writeable = False
    return view


def contact_rows(robot: RobotModel, flags: np.ndarray) -> np.ndarray:
    """The rows of F (and of Jc) that belong to the contacts flagged in `flags`."""
    return np.flatnonzero(np.repeat(flags, robot.force_dims))


@cache
def no_rows(nx: int) -> tuple[np.ndarray, np.ndarray]:
    """No rows at all over x of size nx: a (0, nx) matrix and 0 right-hand sides (read-only)."""
    return selection(nx, 0, 0), zeros(0)


T = TypeVar("T")


class PerContactSet(Generic[T]):
    """A value built by `build(robot, active)` the first time a set of active contacts occurs,
    then reused (a quadruped has 16 sets at most, a biped 4)."""

    def __init__(self, build: Callable[[RobotModel, np.ndarray], T]) -> None:
        self._build = build
        self._robot: RobotModel | None = None
        self._values: dict[bytes, T] = {}

    def get(self, robot: RobotModel, active: np.ndarray) -> T:
        """The value for the contact flags `active` of `robot` (built on first use)."""
        if robot is not self._robot:
            self._robot, self._values = robot, {}
        key = active.tobytes()
        value = self._values.get(key)
        if value is None:
            value = self._values[key] = self._build(robot, active)
        return value


class FixedRows:
    """A matrix of a fixed number of rows over x, allocated on first use for a robot and then
    rewritten in place each tick (zero where its owner never writes)."""

    def __init__(self) -> None:
        self._robot: RobotModel | None = None
        self._A = self._view = np.zeros((0, 0))

    def get(self, robot: RobotModel, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The (n, nx) matrix to write and a read-only view of it to hand out."""
        if robot is not self._robot:
            self._robot = robot
            self._A = np.zeros((n, robot.nx))
            self._view = read_only(self._A)
        return self._A, self._view


@dataclass(frozen=True)
class JacobianRows:
    """The rows of Jc of some contacts, and the matrix [J 0] over x that a task writes them to."""

    index: np.ndarray  # rows of Jc (and of F)
    J: np.ndarray  # the first nv columns of A, rewritten each tick
    view: np.ndarray  # read-only A, handed out

    @classmethod
    def of(cls, robot: RobotModel, flags: np.ndarray) -> "JacobianRows":
        """Rows for the contacts flagged in `flags` (zero until written)."""
        index = contact_rows(robot, flags)
        A = np.zeros((len(index), robot.nx))
        return cls(index, A[:, : robot.nv], read_only(A))

    def write(self, robot: RobotModel) -> np.ndarray:
        """Copy this tick's rows of Jc into A; returns J."""
        self.J[:] = robot.Jc.take(self.index, axis=0)
        return self.J
