"""The pinocchio side of a robot description: `build_robot` makes the `Robot` the sim and the
controller use (free-flyer model, locked joints removed, contact frames added, standing posture),
and `FramePlacements` reads the world placements of its links that the UI draws with.
"""

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
import pinocchio as pin
from scipy.spatial.transform import Rotation

from lab.description import RobotDescription
from lab.protocol import ContactSpec
from lab.urdf_visuals import read_visuals

try:
    from lab import _kernel
except ImportError:  # not built: the frames are placed through pinocchio's Python bindings
    _kernel = None


@dataclass(frozen=True)
class Robot:
    """The pinocchio side of one robot.

    `model` has a free-flyer root and no locked joints; `locked_positions` maps each locked joint
    to the angle it is welded at (the reference posture). Contact i sits at `foot_offsets[i]` (m,
    same axes) in the frame of the URDF link `foot_links[i]`, whose collision geometry it replaces.
    `q_standing` is the reference posture with identity base orientation and the base at the height
    where the lowest contact touches z = 0 (point foot: sphere centre at z = radius; flat foot: sole
    at z = 0).
    """

    description: RobotDescription
    model: pin.Model
    q_standing: np.ndarray
    contacts: tuple[ContactSpec, ...]
    torque_limits: np.ndarray
    locked_positions: dict[str, float]
    foot_links: tuple[str, ...]
    foot_offsets: tuple[tuple[float, float, float], ...]

    @property
    def base_link(self) -> str:
        """The URDF link of the floating base (the body the free flyer moves)."""
        return next(
            f.name for f in self.model.frames if f.type == pin.FrameType.BODY and f.parentJoint == 1
        )

    @cached_property
    def drawn_frames(self) -> tuple[int, ...]:
        """The pinocchio frames `FramePlacements` places: each URDF link with a visual, the base
        link, the contact frames. Read once per robot: a switch back to it shares it
        (lab/world/compiled.py), and the URDF's visuals cost milliseconds to read."""
        model, desc = self.model, self.description
        drawn = {visual.link for visual in read_visuals(desc.urdf_path, desc.package_dirs)}
        drawn.add(self.base_link)
        ids = [
            i
            for i, f in enumerate(model.frames)
            if f.type == pin.FrameType.BODY and f.name in drawn
        ]
        links = {model.frames[i].name for i in ids}
        ids += [model.getFrameId(c.frame) for c in self.contacts if c.frame not in links]
        return tuple(ids)

    @cached_property
    def serialized_model(self) -> str:
        """`model.saveToString()` (pinocchio's serialization, which the native kernel's objects
        load without the GIL; made with it: 0.5-2 ms of CPU), made once per robot."""
        return self.model.saveToString()

    @cached_property
    def joint_names(self) -> tuple[str, ...]:
        """Actuated joints in pinocchio order (the order of τ and of q[7:], v[6:]); read once
        (the drawing state sends them with every message)."""
        return tuple(self.model.names[2:])


def _reference_posture(model: pin.Model, desc: RobotDescription) -> np.ndarray:
    """The SRDF's posture `desc.posture`, or the neutral configuration for a robot without an
    SRDF (its `standing_joints` then give the posture)."""
    if desc.srdf_path is None:
        return pin.neutral(model)
    pin.loadReferenceConfigurations(model, str(desc.srdf_path), False)
    if desc.posture not in model.referenceConfigurations:
        known = ", ".join(pair.key() for pair in model.referenceConfigurations)
        raise KeyError(f"robot {desc.name!r}: SRDF has no posture {desc.posture!r} ({known})")
    return np.array(model.referenceConfigurations[desc.posture])


def _contact_heights(model: pin.Model, q: np.ndarray, contacts: tuple[ContactSpec, ...]):
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return np.array(
        [
            data.oMf[model.getFrameId(c.frame)].translation[2]
            - (c.radius if c.kind == "point" else 0.0)
            for c in contacts
        ]
    )


def _add_frames(model: pin.Model, desc: RobotDescription) -> None:
    """Add the description's contact frames (`added_frames`) to `model`, in place."""
    for frame in desc.added_frames:
        if not model.existFrame(frame.parent):
            raise KeyError(f"robot {desc.name!r}: no frame {frame.parent!r} for {frame.name!r}")
        parent_id = model.getFrameId(frame.parent)
        parent = model.frames[parent_id]
        offset = pin.SE3(np.eye(3), np.array(frame.offset))
        model.addFrame(
            pin.Frame(
                frame.name,
                parent.parentJoint,
                parent_id,
                parent.placement * offset,
                pin.FrameType.OP_FRAME,
            )
        )


def build_robot(desc: RobotDescription) -> Robot:
    """Build the pinocchio model (free flyer, locked joints removed, contact frames added)."""
    full = pin.buildModelFromUrdf(str(desc.urdf_path), pin.JointModelFreeFlyer())
    q_ref = _reference_posture(full, desc)
    for joint, angle in desc.standing_joints.items():
        if not full.existJointName(joint):
            raise KeyError(f"robot {desc.name!r}: standing joint {joint!r} is not in the URDF")
        q_ref[full.joints[full.getJointId(joint)].idx_q] = angle
    missing = [j for j in desc.locked_joints if not full.existJointName(j)]
    if missing:
        raise KeyError(f"robot {desc.name!r}: locked joints {missing} are not in the URDF")
    locked_ids = [full.getJointId(j) for j in desc.locked_joints]
    locked_positions = {
        j: float(q_ref[full.joints[full.getJointId(j)].idx_q]) for j in desc.locked_joints
    }
    model = pin.buildReducedModel(full, locked_ids, q_ref) if locked_ids else full
    _add_frames(model, desc)
    added = {frame.name: frame for frame in desc.added_frames}
    foot_links, foot_offsets = [], []
    for c in desc.contacts:
        if not model.existFrame(c.frame):
            raise KeyError(f"robot {desc.name!r}: contact frame {c.frame!r} is not in the model")
        link, offset = (
            (added[c.frame].parent, added[c.frame].offset)
            if c.frame in added
            else (c.frame, (0.0, 0.0, 0.0))
        )
        if model.frames[model.getFrameId(link)].type != pin.FrameType.BODY:
            raise ValueError(f"robot {desc.name!r}: contact {c.name!r} must hang on a URDF link")
        foot_links.append(link)
        foot_offsets.append(offset)

    q = pin.neutral(model)
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        src = full.joints[full.getJointId(model.names[jid])]
        q[joint.idx_q : joint.idx_q + joint.nq] = q_ref[src.idx_q : src.idx_q + src.nq]
    q[:7] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    q[2] = -_contact_heights(model, q, desc.contacts).min()

    effort = np.array(model.effortLimit[6:], dtype=float)
    if desc.torque_limit is not None:
        effort[:] = desc.torque_limit
    if not np.all(np.isfinite(effort) & (effort > 0.0)):
        raise ValueError(f"robot {desc.name!r}: torque limits must be positive and finite")
    return Robot(
        desc,
        model,
        q,
        desc.contacts,
        effort,
        locked_positions,
        tuple(foot_links),
        tuple(foot_offsets),
    )


def with_raised_contact(robot: Robot, contact: str, rise: float) -> Robot:
    """`robot` whose standing posture has contact `contact` `rise` m higher and otherwise where
    it was (same orientation; the base and the other feet stay): a foot standing on a block.
    The leg's joints are found by closed-loop inverse kinematics on the contact frame (pinocchio's
    frame Jacobian, base columns left out); raises ValueError if they cannot reach it."""
    names = [c.name for c in robot.contacts]
    if contact not in names:
        raise KeyError(f"robot {robot.description.name!r} has no contact {contact!r} ({names})")
    model, data = robot.model, robot.model.createData()
    frame = model.getFrameId(robot.contacts[names.index(contact)].frame)
    q = robot.q_standing.copy()
    pin.framesForwardKinematics(model, data, q)
    target = pin.SE3(data.oMf[frame].rotation, data.oMf[frame].translation + np.array([0, 0, rise]))
    for _ in range(100):
        pin.framesForwardKinematics(model, data, q)
        error = pin.log6(data.oMf[frame].actInv(target)).vector
        if np.linalg.norm(error) < 1e-10:
            return replace(robot, q_standing=q)
        jacobian = pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL)
        step = np.zeros(model.nv)
        step[6:] = np.linalg.lstsq(jacobian[:, 6:], error, rcond=None)[0]
        q = pin.integrate(model, q, step)
    raise ValueError(f"robot {robot.description.name!r}: contact {contact!r} cannot rise {rise} m")


class FramePlacements:
    """World placements of the frames the UI draws with: every URDF link that has a visual
    (locked joints' links included), the base link and the contact frames. They are the
    `frames` of a `lab/state` message, from which the UI poses each link's visual meshes; only
    those links, as each costs the sim loop a few microseconds per message.

    With the native kernel built (`native` None or True) one call of `lab._kernel` computes
    them all (pinocchio's forward kinematics and frame placements, Eigen's quaternions);
    without it (or `native=False`) pinocchio's Python bindings and scipy do."""

    def __init__(self, robot: Robot, native: bool | None = None) -> None:
        model = robot.model
        self.ids = robot.drawn_frames  # pinocchio frame indices (a joint and its link share a name)
        self.names = tuple(model.frames[i].name for i in self.ids)
        self._name_list = list(self.names)
        ids = list(self.ids)
        if native and _kernel is None:
            raise RuntimeError("the native kernel (lab._kernel) is not built")
        self.native = _kernel is not None and native is not False
        self._placements = np.empty((len(ids), 7))  # rows: x, y, z, qx, qy, qz, qw
        if self.native:
            self._kernel = _kernel.FramePlacements(robot.serialized_model, ids)
        else:
            self._joints = np.array([model.frames[i].parentJoint for i in ids])
            self._in_joint = np.array([model.frames[i].placement.homogeneous for i in ids])
            self._model = model
            self._data = model.createData()  # scratch: the controller's model data is not moved

    def placements(self, q: np.ndarray) -> np.ndarray:
        """Each frame's position (m) and quaternion (x, y, z, w) in the world at configuration
        q, one row of 7 per frame (an array this object reuses)."""
        if self.native:
            self._kernel.compute(q, self._placements)
            return self._placements
        # One placement per joint from pinocchio, then each frame's fixed placement in its joint
        # applied to all frames at once: reading each frame from pinocchio cost about 5x more
        # (the rotations are orthonormal, so scipy need not orthonormalise them).
        pin.forwardKinematics(self._model, self._data, q)
        joints = np.array([placement.homogeneous for placement in self._data.oMi])
        world = joints[self._joints] @ self._in_joint
        self._placements[:, :3] = world[:, :3, 3]
        rotations = Rotation.from_matrix(world[:, :3, :3], assume_valid=True)
        self._placements[:, 3:] = rotations.as_quat()
        return self._placements

    def message(self, q: np.ndarray) -> dict[str, list]:
        """Names, positions (m) and quaternions (x, y, z, w) in the world at configuration q."""
        placements = self.placements(q)
        return {
            "names": self._name_list.copy(),
            "positions": placements[:, :3].tolist(),
            "quaternions": placements[:, 3:].tolist(),
        }
