"""Balance: the standing behaviour. It holds the references of the standing posture.

The CoM stays where the standing posture puts it over the feet, the base level at the standing
height, the joints at the reference posture, all feet in contact — wherever the robot stands and
whichever way it faces when the behaviour starts (after walking, say). The velocity command is
ignored: a standing robot does not walk.

On a native tick the line balance runs in C++ (cpp/behaviours/balance.cpp, line_balance.cpp;
`native.py`).
"""

import numpy as np
import pinocchio as pin

from lab.controller.behaviours.base import NoOptions
from lab.controller.behaviours.line_balance import (
    LineBalanceGains,
    composite_inertia,
    line_balance_offset,
)
from lab.controller.behaviours.native import NativeTwin
from lab.controller.model import RobotModel
from lab.controller.references import References

try:
    from lab._kernel import Balance as NativeBalance
except ImportError:  # the native kernel is not built: every tick runs in Python
    NativeBalance = None


def standing_model(robot: RobotModel, q_standing: np.ndarray) -> RobotModel:
    """A scratch model of `robot` at rest in `q_standing`: the shared model, which follows the
    real robot from tick to tick, does not move."""
    standing = robot.scratch()
    standing.update(q_standing, np.zeros(robot.nv))
    return standing


def references_at_rest(standing: RobotModel) -> References:
    """References that hold the robot still in the posture `standing` is at (a model from
    `standing_model`): its CoM (world, m), base height (m), heading, joint positions, every foot
    in contact."""
    yaw = pin.rpy.matrixToRpy(standing.base_rotation)[2]
    return References(
        com=com_over_support(standing),
        posture=standing.joint_positions.copy(),
        base_height=float(standing.base_position[2]),
        base_rotation=pin.rpy.rpyToMatrix(0.0, 0.0, yaw),
        contact_active=np.ones(len(standing.contacts), dtype=bool),
    )


def com_over_support(standing: RobotModel) -> np.ndarray:
    """The standing CoM (world, m), moved horizontally onto the line between the feet when the
    robot stands on two point feet (Bolt): their support is that line, and a CoM beside it
    cannot be held still (no moment about a point foot)."""
    com = standing.com.copy()
    if len(standing.contacts) != 2 or any(c.kind != "point" for c in standing.contacts):
        return com
    a, b = standing.contact_positions[:, :2]
    line = b - a
    s = np.clip((com[:2] - a) @ line / (line @ line), 0.0, 1.0)
    com[:2] = a + s * line
    return com


def standing_references(robot: RobotModel, q_standing: np.ndarray) -> References:
    """References that hold the robot still in its standing posture `q_standing` (pinocchio q)."""
    return references_at_rest(standing_model(robot, q_standing))


class Balance(NativeTwin, NoOptions):
    """Stand still on every foot."""

    name = "stand"
    lifts_feet = False

    def __init__(self, robot: RobotModel, q_standing: np.ndarray) -> None:
        """Start from the robot's current state (the model is up to date)."""
        here = q_standing.copy()
        here[:2] = robot.base_position[:2]
        yaw = pin.rpy.matrixToRpy(robot.base_rotation)[2]
        here[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, 0.0, yaw)).coeffs()
        standing = standing_model(robot, here)
        self.references = references_at_rest(standing)
        # On two point feet the CoM reference leans off the foot line to balance about it.
        self._on_line = len(robot.contacts) == 2 and all(c.kind == "point" for c in robot.contacts)
        self._com_on_line = self.references.com.copy()
        self._inertia = composite_inertia(standing) if self._on_line else np.zeros((3, 3))
        self.line_gains = LineBalanceGains()
        if NativeBalance is not None and self._on_line:
            self._native = NativeBalance()

    @property
    def idle(self) -> bool:
        """Whether update() changes nothing (behaviours/base.py): standing off a foot line, and
        not a subclass (Stance) with an update of its own."""
        return not self._on_line and type(self).update is Balance.update

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Standing on a foot line (two point feet), the CoM reference leans to balance about
        it (`line_balance.py`); otherwise nothing changes while standing."""
        if not self._native_tick(t, robot, command, touching):
            self._lean(robot)

    def _lean(self, robot: RobotModel) -> None:
        """On a foot line, the CoM reference: the one on the line leaned to balance about it."""
        if self._on_line:
            offset = line_balance_offset(
                robot, (0, 1), self.references.base_rotation, self._inertia, self.line_gains
            )
            self.references.com[:] = self._com_on_line + offset
