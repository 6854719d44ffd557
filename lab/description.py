"""Robot descriptions: `robots/<name>.toml` as plain data, and the pinocchio model built from it.

A description names the source URDF and SRDF in example-robot-data, the reference posture, the feet
(`ContactSpec`), joints locked at the reference posture, torque limits, friction, and the
controller's default stack and gains. `build_robot` turns it into a `Robot`: the pinocchio model
with a free-flyer root (locked joints removed, contact frames added) and the standing posture.
"""

import importlib.metadata
import tomllib
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import pinocchio as pin

from lab.controller.contact import ContactSpec
from lab.controller.tasks import TaskGains

ROBOTS_DIR = Path(__file__).resolve().parent.parent / "robots"
ROBOT_NAMES: tuple[str, ...] = tuple(sorted(p.stem for p in ROBOTS_DIR.glob("*.toml")))


@cache
def example_robot_data_share() -> Path:
    """The `share` folder holding `example-robot-data/robots` (the root of `package://` URIs)."""
    dist = importlib.metadata.distribution("example-robot-data")
    for file in dist.files or ():
        parts = file.parts
        if "example-robot-data" in parts and "robots" in parts:
            share = Path(*parts[: parts.index("example-robot-data")])
            return Path(str(dist.locate_file(share))).resolve()
    raise FileNotFoundError("example-robot-data is installed but ships no robots/ folder")


@dataclass(frozen=True)
class ContactFrame:
    """A frame added to the pinocchio model at `offset` (m) in the frame `parent`, same axes."""

    name: str
    parent: str
    offset: tuple[float, float, float]


@dataclass(frozen=True)
class RobotDescription:
    name: str
    urdf_path: Path
    srdf_path: Path
    package_dirs: tuple[Path, ...]
    posture: str
    friction: float
    contacts: tuple[ContactSpec, ...]
    added_frames: tuple[ContactFrame, ...]
    locked_joints: tuple[str, ...]
    torque_limit: float | None
    stack: tuple[tuple[str, ...], ...]
    gains: dict[str, TaskGains]
    kernel: str | None = None  # native | python: which kernel runs the tick (None: native)


def _contact(name: str, table: dict) -> tuple[ContactSpec, ContactFrame | None]:
    known = {"name", "frame", "kind", "radius", "half_length", "half_width", "parent", "offset"}
    unknown = set(table) - known
    if unknown:
        raise ValueError(f"robot {name!r}: unknown contact keys {sorted(unknown)}")
    spec = ContactSpec(
        name=table["name"],
        frame=table["frame"],
        kind=table.get("kind", "point"),
        radius=float(table.get("radius", 0.0)),
        half_length=float(table.get("half_length", 0.0)),
        half_width=float(table.get("half_width", 0.0)),
    )
    if spec.kind not in ("point", "flat"):
        raise ValueError(f"robot {name!r}: contact {spec.name!r} kind must be 'point' or 'flat'")
    if spec.kind == "point" and spec.radius <= 0.0:
        raise ValueError(f"robot {name!r}: point contact {spec.name!r} needs a radius > 0")
    if spec.kind == "flat" and min(spec.half_length, spec.half_width) <= 0.0:
        raise ValueError(f"robot {name!r}: flat contact {spec.name!r} needs half_length/width")
    if "parent" not in table:
        return spec, None
    offset = tuple(float(x) for x in table.get("offset", (0.0, 0.0, 0.0)))
    if len(offset) != 3:
        raise ValueError(f"robot {name!r}: contact {spec.name!r} offset must have 3 entries")
    return spec, ContactFrame(spec.frame, table["parent"], offset)


def load_description(name: str) -> RobotDescription:
    """Read `robots/<name>.toml`; an unknown name raises KeyError naming the known robots."""
    if name not in ROBOT_NAMES:
        raise KeyError(f"unknown robot {name!r}; known robots: {', '.join(ROBOT_NAMES)}")
    with (ROBOTS_DIR / f"{name}.toml").open("rb") as f:
        data = tomllib.load(f)
    share = example_robot_data_share()
    robots = share / "example-robot-data" / "robots"
    pairs = [_contact(name, c) for c in data["contacts"]]
    gains = {task: TaskGains(**values) for task, values in data.get("gains", {}).items()}
    torque_limit = data.get("torque_limit")
    kernel = data.get("kernel")
    if kernel not in (None, "native", "python"):
        raise ValueError(f"robot {name!r}: kernel must be 'native' or 'python', got {kernel!r}")
    return RobotDescription(
        name=name,
        urdf_path=robots / data["urdf"],
        srdf_path=robots / data["srdf"],
        package_dirs=(share,),
        posture=data.get("posture", "standing"),
        friction=float(data["friction"]),
        contacts=tuple(spec for spec, _ in pairs),
        added_frames=tuple(frame for _, frame in pairs if frame is not None),
        locked_joints=tuple(data.get("locked_joints", ())),
        torque_limit=None if torque_limit is None else float(torque_limit),
        stack=tuple(tuple(level) for level in data["stack"]),
        gains=gains,
        kernel=kernel,
    )


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

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Actuated joints in pinocchio order (the order of τ and of q[7:], v[6:])."""
        return tuple(self.model.names[2:])


def _reference_posture(model: pin.Model, desc: RobotDescription) -> np.ndarray:
    pin.loadReferenceConfigurations(model, str(desc.srdf_path), False)
    if desc.posture not in model.referenceConfigurations:
        known = ", ".join(model.referenceConfigurations.keys())
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


def add_frames(model: pin.Model, desc: RobotDescription) -> None:
    """Add the description's contact frames (`added_frames`) to `model`, in place; every model of
    the robot (the controller's, the drawing's) names the same frames."""
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
    missing = [j for j in desc.locked_joints if not full.existJointName(j)]
    if missing:
        raise KeyError(f"robot {desc.name!r}: locked joints {missing} are not in the URDF")
    locked_ids = [full.getJointId(j) for j in desc.locked_joints]
    locked_positions = {
        j: float(q_ref[full.joints[full.getJointId(j)].idx_q]) for j in desc.locked_joints
    }
    model = pin.buildReducedModel(full, locked_ids, q_ref) if locked_ids else full
    add_frames(model, desc)
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
