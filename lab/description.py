"""Robot descriptions: `robots/<name>.toml` as plain data (light: no pinocchio, the UI reads it).

A description names the source URDF and SRDF in example-robot-data, the reference posture, the feet
(`ContactSpec`), the hands (end-effector frames of the `hands` task), joints locked at the
reference posture, torque limits, friction, and the controller's default stack and gains.
`lab.robot.build_robot` turns it into a `Robot`: the pinocchio model with a free-flyer root
(locked joints removed, contact frames added) and the standing posture.
"""

import importlib.metadata
import tomllib
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

from lab.protocol import ContactSpec, TaskGains

ROBOTS_DIR = Path(__file__).resolve().parent.parent / "robots"
STACKS_DIR = ROBOTS_DIR.parent / "stacks"  # the stack presets (lab/stack_presets.py)
STACK_PRESET_NAMES: tuple[str, ...] = tuple(sorted(p.stem for p in STACKS_DIR.glob("*.toml")))


def robot_names() -> tuple[str, ...]:
    """The robots described in robots/ now (`lab robot new` may have added one since start)."""
    return tuple(sorted(p.stem for p in ROBOTS_DIR.glob("*.toml")))


ROBOT_NAMES: tuple[str, ...] = robot_names()  # the robots at start: what servers offer


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
    srdf_path: Path | None  # None: the posture is `standing_joints` (others at 0)
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
    # Joint angles (rad) that replace the SRDF posture's in the standing posture, by joint name.
    standing_joints: dict[str, float] = field(default_factory=dict)
    # The foothold planner of a walking gait on this robot when the gait command names none
    # (None: the behaviour's own default, robo-centric).
    footholds: str | None = None
    # The hands task's hands, (name, frame) each, in the order of the references' hand rows.
    hands: tuple[tuple[str, str], ...] = ()
    # Each hand's joints option, "all" or "arm" (lab/controller/tasks/hands.py), in that order.
    hand_joints: tuple[str, ...] = ()
    # The stack preset (stacks/<name>.toml) the `stance` command brings when the stack running
    # cannot lift a sole: Herzog's Table 4, or its variant for a robot with free arms.
    stance_stack: str = "herzog_table4"
    # `[touchdown]`: the haptic touch detector's thresholds on the estimated contact force
    # (lab/realism/contact_estimate.py's TouchThresholds fields; absent: its defaults).
    touchdown: dict[str, float] = field(default_factory=dict)


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
    known = robot_names()
    if name not in known:
        raise KeyError(f"unknown robot {name!r}; known robots: {', '.join(known)}")
    return read_description(ROBOTS_DIR / f"{name}.toml")


def read_description(path: Path) -> RobotDescription:
    """Read a robot description file; the robot's name is the file's stem."""
    name = path.stem
    with path.open("rb") as f:
        data = tomllib.load(f)
    share = example_robot_data_share()
    robots = share / "example-robot-data" / "robots"
    pairs = [_contact(name, c) for c in data["contacts"]]
    gains = {task: TaskGains(**values) for task, values in data.get("gains", {}).items()}
    torque_limit = data.get("torque_limit")
    kernel = data.get("kernel")
    hands = _hands(name, data.get("hands", {}))
    if kernel not in (None, "native", "python"):
        raise ValueError(f"robot {name!r}: kernel must be 'native' or 'python', got {kernel!r}")
    return RobotDescription(
        name=name,
        urdf_path=robots / data["urdf"],
        srdf_path=robots / data["srdf"] if "srdf" in data else None,
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
        standing_joints={j: float(a) for j, a in data.get("standing_joints", {}).items()},
        footholds=data.get("footholds"),
        hands=tuple((hand, frame) for hand, frame, _ in hands),
        hand_joints=tuple(joints for _, _, joints in hands),
        touchdown=_touchdown(name, data.get("touchdown", {})),
        stance_stack=_stance_stack(name, data.get("stance_stack", "herzog_table4")),
    )


def _stance_stack(name: str, preset: object) -> str:
    """`stance_stack`: the name of a stack preset in stacks/."""
    if preset not in STACK_PRESET_NAMES:
        known = ", ".join(STACK_PRESET_NAMES)
        raise ValueError(f"robot {name!r}: stance_stack {preset!r} is no stack preset ({known})")
    return preset


TOUCHDOWN_KEYS = {"on", "off", "min_force", "accel_filter_hz"}


def _touchdown(name: str, table: object) -> dict[str, float]:
    """`[touchdown]`: known keys, numbers."""
    if not isinstance(table, dict) or not all(isinstance(v, int | float) for v in table.values()):
        raise ValueError(f"robot {name!r}: [touchdown] must map names to numbers")
    unknown = set(table) - TOUCHDOWN_KEYS
    if unknown:
        raise ValueError(f"robot {name!r}: unknown [touchdown] keys {sorted(unknown)}")
    return {key: float(value) for key, value in table.items()}


def _hands(name: str, table: object) -> list[tuple[str, str, str]]:
    """`[hands]`: hand name = frame name, or = { frame = ..., joints = "all" | "arm" } (the
    joints its rows may use, lab/controller/tasks/hands.py; a bare frame name: "all"); (hand,
    frame, joints) each."""
    if not isinstance(table, dict):
        raise ValueError(f"robot {name!r}: [hands] must map hand names to frame names")
    hands = []
    for hand, entry in table.items():
        if isinstance(entry, str):
            hands.append((hand, entry, "all"))
            continue
        if (
            not isinstance(entry, dict)
            or set(entry) - {"frame", "joints"}
            or not isinstance(entry.get("frame"), str)
            or entry.get("joints", "all") not in ("all", "arm")
        ):
            raise ValueError(
                f"robot {name!r}: [hands] {hand!r} must be a frame name or "
                '{ frame = "<frame>", joints = "all" | "arm" }'
            )
        hands.append((hand, entry["frame"], entry.get("joints", "all")))
    return hands
