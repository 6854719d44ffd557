"""The hands task: each hand (an end-effector frame the controller was given, `set_hands`) tracks
its pose target in the references, one instance per hand.

Per hand, with J the frame's Jacobian in LOCAL_WORLD_ALIGNED axes (rows [linear; angular]) and
J̇v its classical drift acceleration, J q̈ + J̇v = a with the PD of Raiola eqs. 7–9 in world axes:
a = [p̈_ref + kp (p_ref − p) + kd (ṗ_ref − ṗ); kp log₃(R_ref Rᵀ) + kd (ω_ref − ω)]. The error is
[p_ref − p (m); log₃(R_ref Rᵀ) (rad)] per hand, world axes. References without hand targets give
no rows.

A target in the trunk's *heading frame* (the hand's `hand_heading` flag) moves with the robot:
its origin is the base's, its axes the world's turned by the trunk's yaw ψ (gravity stays down, so
the trunk's roll and pitch do not tilt it). Its world target is p_ref = p_b + R_ψ p_rel, R_ref =
R_ψ R_rel, and the position rows track r = p − p_b, the hand relative to the base: their Jacobian
is J − J_b (the base's own linear motion cancels: the hand is not asked to drag the base along)
and r̈_ref = R_ψ p̈_rel + 2 ψ̇ ẑ × R_ψ ṗ_rel + ψ̇² ẑ × (ẑ × R_ψ p_rel), the frame's turning fed
forward at the measured yaw rate ψ̇ (ω_ref = ψ̇ ẑ); its yaw acceleration is not (a steered trot's
yaw rate changes only with the command).

Each hand declares which joints its rows may use (`joints`, robots/*.toml's `[hands]`): `"all"`
(the whole robot: a world-frame error is also corrected by moving the base, so a heavily weighted
hand steers the trunk), or `"arm"`: only the hand's own chain from the trunk (the joints that
support it, the free flyer excluded: the Z1's six on the B1, the waist's and the arm's on a
humanoid). An arm hand's rows keep the full J̇v and the measured ṗ, ω, but zero the other
columns of J: the hand cannot push the base or the legs around, and the base's motion reaches the
hand only as an error its PD corrects (as OpenSoT's Cartesian task on a `base_link` or pink's and
mink's relative frame tasks, but with the target still in the world or heading frame).
"""

import numpy as np
import pinocchio as pin

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.rows import FixedRows
from lab.controller.tasks.base import Task, TaskGains, TaskRows, no_task_rows

FRAME = pin.LOCAL_WORLD_ALIGNED
BASE_JOINT = 1  # the free-flyer joint: the trunk
UP = np.array([0.0, 0.0, 1.0])
JOINTS = ("all", "arm")  # which joints a hand's rows use (module docstring)


def heading(base_rotation: np.ndarray) -> np.ndarray:
    """R_ψ: the rotation about world z by the trunk's yaw ψ, the heading of its x axis."""
    x = base_rotation[:, 0]
    turn: np.ndarray = pin.rpy.rpyToMatrix(0.0, 0.0, float(np.arctan2(x[1], x[0])))
    return turn


def heading_rate(base_rotation: np.ndarray, omega: np.ndarray) -> float:
    """ψ̇ (rad/s) of ψ = atan2(x_y, x_x), x the trunk's x axis, at its angular velocity ω (world
    axes): ẋ = ω × x gives ψ̇ = ω_z − x_z (x_x ω_x + x_y ω_y) / (x_x² + x_y²)."""
    x = base_rotation[:, 0]
    return float(omega[2] - x[2] * (x[0] * omega[0] + x[1] * omega[1]) / (x[0] ** 2 + x[1] ** 2))


def world_target(
    base: pin.SE3, position: np.ndarray, rotation: np.ndarray, in_heading: bool
) -> tuple[np.ndarray, np.ndarray]:
    """A hand's target (position, rotation) in world axes, from the references' (in the
    heading frame of the trunk at placement `base` when `in_heading`)."""
    if not in_heading:
        return position, rotation
    turn = heading(base.rotation)
    return base.translation + turn @ position, turn @ rotation


def hand_frame_ids(model: pin.Model, frames: tuple[str, ...]) -> tuple[int, ...]:
    """The model's index of each hand's body frame (a link: a URDF's fixed joint and its child
    link share a name); raises ValueError naming a frame the model lacks."""
    unknown = [frame for frame in frames if not model.existFrame(frame, pin.BODY)]
    if unknown:
        raise ValueError(f"no frame {', '.join(map(repr, unknown))} in the robot's model")
    return tuple(int(model.getFrameId(frame, pin.BODY)) for frame in frames)


def arm_columns(model: pin.Model, frame_id: int) -> np.ndarray:
    """The velocity indices of the joints that carry this frame from the trunk: its parent
    joint's supports without the universe and the free flyer (BASE_JOINT)."""
    joints = [j for j in model.supports[model.frames[frame_id].parentJoint] if j > BASE_JOINT]
    return np.array(
        [
            v
            for j in joints
            for v in range(model.joints[j].idx_v, model.joints[j].idx_v + model.joints[j].nv)
        ],
        dtype=int,
    )


def hand_joints(frames: tuple[str, ...], joints: tuple[str, ...] | None) -> tuple[str, ...]:
    """Each hand's `joints` option ("all" when None); raises ValueError for another count or an
    unknown value."""
    if joints is None:
        return ("all",) * len(frames)
    if len(joints) != len(frames):
        raise ValueError(f"{len(joints)} hand joints options for {len(frames)} hands")
    unknown = [j for j in joints if j not in JOINTS]
    if unknown:
        raise ValueError(f"hand joints must be 'all' or 'arm', got {', '.join(map(repr, unknown))}")
    return tuple(joints)


class HandsTask(Task):
    """Every hand tracks its pose target (module docstring); 6 rows per hand."""

    name = "hands"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self.frames: tuple[str, ...] = ()
        self.frame_ids: tuple[int, ...] = ()
        self.joints: tuple[str, ...] = ()
        self._other_columns: tuple[np.ndarray | None, ...] = ()  # zeroed per hand; None: all

    def set_frames(
        self, robot: RobotModel, frames: tuple[str, ...], joints: tuple[str, ...] | None = None
    ) -> None:
        """Track these frames, one hand each, in the order of the references' hand rows, each
        with the joints its `joints` option names ("all" or "arm", module docstring; None: all);
        raises ValueError naming a frame the model lacks or a bad option, and keeps the old ones
        then."""
        ids, options = hand_frame_ids(robot.model, frames), hand_joints(frames, joints)
        everything = np.arange(robot.nv)
        self.frame_ids, self.frames, self.joints = ids, frames, options
        self._other_columns = tuple(
            np.setdiff1d(everything, arm_columns(robot.model, fid)) if option == "arm" else None
            for fid, option in zip(ids, options, strict=True)
        )
        self._fixed = FixedRows()  # another number of rows

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        n = len(self.frame_ids)
        if len(refs.hand_position) not in (0, n):  # as the kernel's check_references
            raise ValueError(
                f"references: hand_position has {len(refs.hand_position)} rows, expected 0 or {n}"
            )
        if n == 0 or len(refs.hand_position) == 0:
            return no_task_rows(robot.nx)
        if len(refs.hand_heading) not in (0, n):  # as the kernel's check_references
            raise ValueError(
                f"references: hand_heading has {len(refs.hand_heading)} rows, expected 0 or {n}"
            )
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
            p_ref, v_ref, a_ref = (
                refs.hand_position[k],
                refs.hand_velocity[k],
                refs.hand_acceleration[k],
            )
            R_ref, w_ref = refs.hand_rotation[k], np.zeros(3)
            if len(refs.hand_heading) and refs.hand_heading[k]:  # module docstring
                base = data.oMi[BASE_JOINT]
                J_b = pin.getJointJacobian(model, data, BASE_JOINT, FRAME)
                A[6 * k : 6 * k + 3, : robot.nv] -= J_b[:3]
                drift[:3] -= pin.getClassicalAcceleration(model, data, BASE_JOINT, FRAME).linear
                base_velocity = J_b @ robot.v
                turn, rate = heading(base.rotation), heading_rate(base.rotation, base_velocity[3:])
                r_ref, v_rel = turn @ p_ref, turn @ v_ref
                p_ref = base.translation + r_ref
                v_ref = base_velocity[:3] + rate * np.cross(UP, r_ref) + v_rel
                a_ref = (
                    turn @ a_ref
                    + 2.0 * rate * np.cross(UP, v_rel)
                    + rate**2 * np.cross(UP, np.cross(UP, r_ref))
                )
                R_ref, w_ref = turn @ R_ref, rate * UP
            others = self._other_columns[k]
            if others is not None:  # an arm hand: its chain's columns only
                A[rows, others] = 0.0
            e_p = p_ref - placement.translation
            e_r = pin.log3(R_ref @ placement.rotation.T)
            error[rows] = np.concatenate((e_p, e_r))
            b[6 * k : 6 * k + 3] = a_ref + kp * e_p + kd * (v_ref - velocity[:3])
            b[6 * k + 3 : 6 * k + 6] = kp * e_r + kd * (w_ref - velocity[3:])
            b[rows] -= drift
        return TaskRows(view, b, error)
