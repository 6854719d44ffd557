"""Tasks: equality rows `A x = b` over x = [q̈, F], each with PD gains and a weight.

A motion task asks an operational-space acceleration `J q̈ + J̇v = a_des` with the PD law
`a_des = a_ref + kp e + kd ė` (Raiola eqs. 7–9); a force task asks F directly. `error` holds the
tracking error of the last `rows` call, for telemetry and tests.

Rows are built every tick, so a task keeps its matrix A from tick to tick and rewrites in place
only the entries that move (zero elsewhere); what depends only on which contacts are active
(index arrays, row counts) is computed once per contact set. The A a task returns is a read-only
view, valid until the task's next `rows` call. Small products use `ndarray.dot`, which costs
half the call overhead of `@` (same result).
"""

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Generic, TypeVar

import numpy as np
import pinocchio as pin

from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.references import References
from lab.protocol import TaskGains


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
    """No rows at all (read-only: shared by every tick)."""
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
        if robot is not self._robot:
            self._robot, self._values = robot, {}
        key = active.tobytes()
        value = self._values.get(key)
        if value is None:
            value = self._values[key] = self._build(robot, active)
        return value


class Task:
    """Base class: a named producer of equality rows."""

    name: str = ""

    def __init__(self, gains: TaskGains | None = None) -> None:
        self.gains = gains or TaskGains()
        self.error = np.zeros(0)
        self._robot: RobotModel | None = None
        self._A = self._A_view = np.zeros((0, 0))

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _matrix(self, robot: RobotModel, n: int) -> tuple[np.ndarray, np.ndarray]:
        """The task's n rows over x (zero until written) and a read-only view to hand out, for
        a task with a fixed number of rows: allocated on its first tick, then reused."""
        if robot is not self._robot:
            self._robot = robot
            self._A = np.zeros((n, robot.nx))
            self._A_view = read_only(self._A)
        return self._A, self._A_view


@dataclass(frozen=True)
class JacobianRows:
    """The rows of Jc of some contacts, and the matrix [J 0] over x that a task writes them to."""

    index: np.ndarray  # rows of Jc (and of F)
    J: np.ndarray  # the first nv columns of A, rewritten each tick
    view: np.ndarray  # read-only A, handed out

    @classmethod
    def of(cls, robot: RobotModel, flags: np.ndarray) -> "JacobianRows":
        index = contact_rows(robot, flags)
        A = np.zeros((len(index), robot.nx))
        return cls(index, A[:, : robot.nv], read_only(A))

    def write(self, robot: RobotModel) -> np.ndarray:
        """Copy this tick's rows of Jc into A; returns J."""
        self.J[:] = robot.Jc.take(self.index, axis=0)
        return self.J


class ContactTask(Task):
    """Feet in contact do not accelerate: J_c q̈ = −J̇_c v − kd J_c v (Raiola eq. 7).

    kd = 0 is the paper's task; a small kd damps the drift of a foot that slipped.
    """

    name = "contact"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._support = PerContactSet(JacobianRows.of)

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        support = self._support.get(robot, refs.contact_active)
        velocity = support.write(robot).dot(robot.v)
        b = -robot.Jc_dot_v[support.index]
        if self.gains.kd:
            b -= self.gains.kd * velocity
        self.error = velocity
        return support.view, b


class BaseOrientationTask(Task):
    """Base angular acceleration in world axes tracks ω̇ = kp log(R_ref Rᵀ) + kd (ω_ref − ω).

    The free-flyer angular acceleration is in the base frame, so the rows are simply R.
    """

    name = "base_orientation"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        R = robot.base_rotation
        e = pin.log3(refs.base_rotation.dot(R.T))
        de = refs.base_angular_velocity - R.dot(robot.v[3:6])  # ω in world axes
        A, view = self._matrix(robot, 3)
        A[:, 3:6] = R
        self.error = e
        return view, self.gains.kp * e + self.gains.kd * de


class ComTask(Task):
    """CoM acceleration J_com q̈ + J̇_com v = kp (c_ref − c) + kd (ċ_ref − ċ)."""

    name = "com"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        e = refs.com - robot.com
        de = refs.com_velocity - robot.com_velocity
        A, view = self._matrix(robot, 3)
        A[:, : robot.nv] = robot.Jcom
        self.error = e
        return view, self.gains.kp * e + self.gains.kd * de - robot.com_drift


class BaseHeightTask(Task):
    """Vertical base acceleration tracks the base-height reference.

    World base acceleration is d/dt(R v_b) = R (v̇_b + ω_b × v_b); only its z row is used.
    """

    name = "base_height"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        R = robot.base_rotation
        v_lin, w = robot.v[:3], robot.v[3:6]
        e = refs.base_height - robot.base_position[2]
        de = -(R @ v_lin)[2]
        A, view = self._matrix(robot, 1)
        A[0, :3] = R[2]
        drift = (R @ np.cross(w, v_lin))[2]
        self.error = np.array([e])
        return view, np.array([self.gains.kp * e + self.gains.kd * de - drift])


class PostureTask(Task):
    """Joint accelerations q̈_j = kp (q_ref − q_j) − kd q̇_j (Raiola eq. 9)."""

    name = "posture"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        e = refs.posture - robot.q[7:]
        self.error = e
        b = self.gains.kp * e - self.gains.kd * robot.v[BASE_DOF:]
        return selection(robot.nx, BASE_DOF, robot.nv), b


class ForceTask(Task):
    """Contact-force regularization: F → 0 (the minimum-force load distribution, W_F = I)."""

    name = "forces"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        self.error = zeros(0)
        return selection(robot.nx, robot.nv, robot.nx), zeros(robot.nf)


class FrameTask(Task):
    """An SE3 frame tracks a target pose: J q̈ + J̇v = kp log6(oMf⁻¹ oM_ref) + kd (0 − ν).

    Rows and error are in the frame's local coordinates.
    """

    name = "frame"

    def __init__(self, frame: str, target: pin.SE3, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self.name = f"frame:{frame}"
        self.frame = frame
        self.target = target

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        model, data = robot.model, robot.data
        fid = model.getFrameId(self.frame)
        current = data.oMf[fid]
        e = pin.log6(current.actInv(self.target)).vector
        velocity = pin.getFrameVelocity(model, data, fid, pin.LOCAL).vector
        drift = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL).vector
        A, view = self._matrix(robot, 6)
        A[:, : robot.nv] = pin.getFrameJacobian(model, data, fid, pin.LOCAL)
        self.error = e
        return view, self.gains.kp * e - self.gains.kd * velocity - drift


TASK_TYPES: dict[str, type[Task]] = {
    t.name: t
    for t in (ContactTask, BaseOrientationTask, ComTask, BaseHeightTask, PostureTask, ForceTask)
}

# Tasks defined in other modules register themselves in TASK_TYPES (after it exists above).
from lab.controller import momentum_task, objectives, trunk_tasks, walk_tasks  # noqa: E402, F401
