"""`lab robot new NAME --urdf PATH`: a first robots/<name>.toml from a URDF, for the user to edit.

What it guesses, and how (each written as a comment in the file):
- **the feet** — the leaves of the kinematic tree (links that are no joint's parent) lowest at
  the reference posture, within `FOOT_BAND` of the lowest one. A leaf whose collision is one
  sphere is a point foot (the sphere's centre and radius); a leaf with several collision shapes
  is a flat sole (the rectangle that holds them, at their lowest point); a leaf with one mesh or
  box is a point foot at the shape's lowest centre, with half its smallest width as radius.
- **the posture** — the SRDF's `standing`-like reference posture when an SRDF is given (its first
  one otherwise), the URDF's zero posture when not; then a short settling run under the default
  controller, whose final joint angles become `standing_joints`.
- **the gains** — the lab's standard ones: every task is a PD on accelerations (q̈ = kp e + kd ė),
  so its gains carry no mass; the mass enters through the mass matrix in the dynamics.
- **the torque limits** — the URDF's `effort`, which `lab.robot` reads (none is written).
"""

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from lab.description import ROBOTS_DIR, example_robot_data_share

FOOT_BAND = 0.03  # m: leaves this close to the lowest one are feet
SETTLE_SECONDS = 1.0
NAME = re.compile(r"[a-z][a-z0-9_]*")


@dataclass(frozen=True)
class FootGuess:
    """A foot found at a leaf link: its contact shape in the link's frame."""

    link: str
    kind: str  # point | flat
    offset: tuple[float, float, float]
    radius: float = 0.0
    half_length: float = 0.0
    half_width: float = 0.0


def resolve_urdf(source: str) -> tuple[Path, Path | None]:
    """A URDF path, or an example-robot-data robot (`go1` → go1_description/urdf/go1.urdf),
    and the SRDF beside it, if any."""
    path = Path(source)
    if path.suffix != ".urdf":
        robots = example_robot_data_share() / "example-robot-data" / "robots"
        path = robots / f"{source}_description" / "urdf" / f"{source}.urdf"
        if not path.exists():
            raise FileNotFoundError(
                f"{source!r} is neither a .urdf file nor an example-robot-data robot "
                f"(no {path.relative_to(robots)})"
            )
    if not path.exists():
        raise FileNotFoundError(f"no URDF at {path}")
    srdf = path.parent.parent / "srdf" / f"{path.stem}.srdf"
    return path.resolve(), srdf.resolve() if srdf.exists() else None


def _leaves(root: ET.Element) -> list[str]:
    parents = {joint.find("parent").get("link") for joint in root.findall("joint")}
    return [link.get("name") for link in root.findall("link") if link.get("name") not in parents]


def _shape_extent(geometry: ET.Element, base: Path) -> np.ndarray:
    """The half extents (x, y, z) of a collision geometry about its origin."""
    if (box := geometry.find("box")) is not None:
        return 0.5 * np.array([float(x) for x in box.get("size").split()])
    if (sphere := geometry.find("sphere")) is not None:
        return np.full(3, float(sphere.get("radius")))
    if (cylinder := geometry.find("cylinder")) is not None:
        r, half = float(cylinder.get("radius")), 0.5 * float(cylinder.get("length"))
        return np.array([r, r, half])
    if (mesh := geometry.find("mesh")) is not None:
        import trimesh

        filename = mesh.get("filename")
        if filename.startswith("package://"):
            filename = str(example_robot_data_share() / filename.removeprefix("package://"))
        loaded = trimesh.load(str(base / filename), force="mesh")
        bounds = np.asarray(loaded.bounds)
        return 0.5 * (bounds[1] - bounds[0])
    raise ValueError("a collision geometry with no box, sphere, cylinder or mesh")


def _foot(link: ET.Element, base: Path) -> FootGuess:
    """The contact shape of one foot link (see the module docstring)."""
    shapes = []
    for collision in link.findall("collision"):
        origin = collision.find("origin")
        xyz = (
            np.zeros(3)
            if origin is None
            else np.array([float(x) for x in origin.get("xyz", "0 0 0").split()])
        )
        geometry = collision.find("geometry")
        shapes.append((xyz, _shape_extent(geometry, base), geometry.find("sphere") is not None))
    name = link.get("name")
    if not shapes:
        return FootGuess(name, "point", (0.0, 0.0, 0.0), radius=0.02)
    if len(shapes) == 1:
        (xyz, extent, sphere) = shapes[0]
        if sphere:
            return FootGuess(name, "point", tuple(xyz), radius=float(extent[0]))
        radius = float(min(extent))
        centre = xyz + np.array([0.0, 0.0, radius - extent[2]])  # the ball touches the bottom
        return FootGuess(name, "point", tuple(centre), radius=radius)
    low = np.array([xyz - extent for xyz, extent, _ in shapes]).min(axis=0)
    high = np.array([xyz + extent for xyz, extent, _ in shapes]).max(axis=0)
    centre = 0.5 * (low + high)
    return FootGuess(
        name,
        "flat",
        (float(centre[0]), float(centre[1]), float(low[2])),
        half_length=float(0.5 * (high[0] - low[0])),
        half_width=float(0.5 * (high[1] - low[1])),
    )


def guess_feet(urdf: Path, q: np.ndarray | None = None) -> list[FootGuess]:
    """The feet of the robot in `urdf` at configuration `q` (pinocchio, free flyer; None: the
    neutral one): the lowest leaves (see the module docstring)."""
    root = ET.parse(urdf).getroot()
    model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model) if q is None else q)
    heights = {}
    for leaf in _leaves(root):
        if model.existFrame(leaf) and root.find(f"link[@name='{leaf}']/collision") is not None:
            heights[leaf] = data.oMf[model.getFrameId(leaf)].translation[2]
    if not heights:
        raise ValueError(f"{urdf.name}: no leaf link has a collision shape to stand on")
    lowest = min(heights.values())
    links = {link.get("name"): link for link in root.findall("link")}
    return [
        _foot(links[leaf], urdf.parent)
        for leaf, z in sorted(heights.items())
        if z <= lowest + FOOT_BAND
    ]


def _posture(urdf: Path, srdf: Path | None) -> tuple[str | None, np.ndarray]:
    model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    if srdf is None:
        return None, pin.neutral(model)
    pin.loadReferenceConfigurations(model, str(srdf), False)
    names = [pair.key() for pair in model.referenceConfigurations]
    if not names:
        return None, pin.neutral(model)
    name = next((n for n in names if "stand" in n), names[0])
    return name, np.array(model.referenceConfigurations[name])


def _toml_path(path: Path) -> str:
    robots = example_robot_data_share() / "example-robot-data" / "robots"
    return str(path.relative_to(robots)) if path.is_relative_to(robots) else str(path)


def render(
    name: str, urdf: Path, srdf: Path | None, posture: str | None, feet: list[FootGuess]
) -> str:
    """The text of robots/<name>.toml for these guesses (no standing_joints yet)."""
    flat = any(foot.kind == "flat" for foot in feet)
    limits = '["friction", "cop", "torque_limits"]' if flat else '["friction", "torque_limits"]'
    lines = [
        f"# {name}: written by `lab robot new` from {urdf.name}; edit, then `lab robot check "
        f"{name}`.",
        f'urdf = "{_toml_path(urdf)}"',
    ]
    if srdf is not None and posture is not None:
        lines += [f'srdf = "{_toml_path(srdf)}"', f'posture = "{posture}"']
    lines += [
        "friction = 0.8",
        "# Torque limits: the URDF's effort (set `torque_limit = N m` to override them all).",
        f'stack = [{limits}, ["contact"], ["com", "base_orientation"], ["posture", "forces"]]',
        "",
        f"# The feet: the lowest leaves of the kinematic tree (within {FOOT_BAND * 100:.0f} cm).",
    ]
    for foot in feet:
        offset = ", ".join(f"{x:.4g}" for x in foot.offset)
        lines += ["[[contacts]]", f'name = "{foot.link.lower()}"']
        lines += [f'frame = "{foot.link}_contact"', f'parent = "{foot.link}"']
        lines += [f"offset = [{offset}]"]
        if foot.kind == "point":
            lines += [f"radius = {foot.radius:.4g}", ""]
        else:
            lines += ['kind = "flat"', f"half_length = {foot.half_length:.4g}"]
            lines += [f"half_width = {foot.half_width:.4g}", ""]
    lines += [
        "# Every task is a PD on accelerations, so its gains carry no mass (the lab's standard).",
    ]
    for task, kp, kd in (("com", 100, 20), ("base_orientation", 400, 40), ("posture", 100, 20)):
        lines += [f"[gains.{task}]", f"kp = {kp:.1f}", f"kd = {kd:.1f}", ""]
    lines += ["[gains.forces]", "weight = 1e-3", ""]
    return "\n".join(lines)


def _standing_joints(name: str, seconds: float) -> dict[str, float]:
    """The joint angles after `seconds` of standing under the default controller."""
    from lab.world.session import Session, SessionConfig

    session = Session(SessionConfig(robot=name))
    for _ in range(round(seconds / session.config.timestep)):
        session.tick()
    q, _ = session.plant.state()
    return dict(zip(session.robot.joint_names, (float(a) for a in q[7:]), strict=True))


def new_robot(name: str, source: str, directory: Path = ROBOTS_DIR, settle: bool = True) -> Path:
    """Write `directory/<name>.toml` from `source` (a URDF path or an example-robot-data robot),
    settle it (robots/ only: the session finds robots there), and return the file's path.
    Refuses to overwrite a file."""
    if not NAME.fullmatch(name):
        raise ValueError(f"robot name {name!r}: lower-case letters, digits and _ only")
    path = directory / f"{name}.toml"
    if path.exists():
        raise FileExistsError(f"{path} exists: pick another name or remove it")
    urdf, srdf = resolve_urdf(source)
    posture, q = _posture(urdf, srdf)
    text = render(name, urdf, srdf, posture, guess_feet(urdf, q))
    path.write_text(text)
    if not settle:
        return path
    try:
        joints = _standing_joints(name, SETTLE_SECONDS)
    except Exception as error:  # the file stays for the user to fix; check says what fails
        path.write_text(text + f"\n# The settling run failed: {error}\n")
        return path
    settled = "\n".join(
        f"{joint} = {angle:.4f}" for joint, angle in joints.items() if math.isfinite(angle)
    )
    path.write_text(
        text
        + f"\n# The posture after {SETTLE_SECONDS:g} s of standing under the default stack.\n"
        + "[standing_joints]\n"
        + settled
        + "\n"
    )
    return path
