"""The hands task: each hand (an end-effector frame the controller was given, `set_hands`) tracks
its pose target in the references, one instance per hand.

Per hand, with J the frame's Jacobian in LOCAL_WORLD_ALIGNED axes (rows [linear; angular]) and
J̇v its classical drift acceleration, J q̈ + J̇v = a with the PD of Raiola eqs. 7–9 in world axes:
a = [p̈_ref + kp (p_ref − p) + kd (ṗ_ref − ṗ); kp log₃(R_ref Rᵀ) − kd ω]. The error is
[p_ref − p (m); log₃(R_ref Rᵀ) (rad)] per hand, world axes. References without hand targets give
no rows.
"""

import numpy as np
import pinocchio as pin

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.rows import FixedRows
from lab.controller.tasks.base import Task, TaskGains, TaskRows, no_task_rows

FRAME = pin.LOCAL_WORLD_ALIGNED


def hand_frame_ids(model: pin.Model, frames: tuple[str, ...]) -> tuple[int, ...]:
    """The model's index of each hand's body frame (a link: a URDF's fixed joint and its child
    link share a name); raises ValueError naming a frame the model lacks."""
    unknown = [frame for frame in frames if not model.existFrame(frame, pin.BODY)]
    if unknown:
        raise ValueError(f"no frame {', '.join(map(repr, unknown))} in the robot's model")
    return tuple(int(model.getFrameId(frame, pin.BODY)) for frame in frames)


class HandsTask(Task):
    """Every hand tracks its pose target (module docstring); 6 rows per hand."""

    name = "hands"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self.frames: tuple[str, ...] = ()
        self.frame_ids: tuple[int, ...] = ()

    def set_frames(self, robot: RobotModel, frames: tuple[str, ...]) -> None:
        """Track these frames, one hand each, in the order of the references' hand rows; raises
        ValueError naming a frame the model lacks, and keeps the old ones then."""
        self.frame_ids = hand_frame_ids(robot.model, frames)
        self.frames = frames
        self._fixed = FixedRows()  # another number of rows

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        n = len(self.frame_ids)
        if len(refs.hand_position) not in (0, n):  # as the kernel's check_references
            raise ValueError(
                f"references: hand_position has {len(refs.hand_position)} rows, expected 0 or {n}"
            )
        if n == 0 or len(refs.hand_position) == 0:
            return no_task_rows(robot.nx)
        model, data = robot.model, robot.data
        A, view = self._matrix(robot, 6 * n)
        b = np.empty(6 * n)
        error = np.empty(6 * n)
        kp, kd = self.gains.kp, self.gains.kd
        for k, fid in enumerate(self.frame_ids):
            rows = slice(6 * k, 6 * k + 6)
            J = pin.getFrameJacobian(model, data, fid, FRAME)
            A[rows, : robot.nv] = J
            placement = data.oMf[fid]
            velocity = J @ robot.v
            drift = pin.getFrameClassicalAcceleration(model, data, fid, FRAME).vector
            e_p = refs.hand_position[k] - placement.translation
            e_r = pin.log3(refs.hand_rotation[k] @ placement.rotation.T)
            error[rows] = np.concatenate((e_p, e_r))
            b[6 * k : 6 * k + 3] = (
                refs.hand_acceleration[k] + kp * e_p + kd * (refs.hand_velocity[k] - velocity[:3])
            )
            b[6 * k + 3 : 6 * k + 6] = kp * e_r - kd * velocity[3:]
            b[rows] -= drift
        return TaskRows(view, b, error)
