"""The visual elements of a URDF as plain records: what the browser draws of a robot.

Only `<link><visual>` is read (origin, geometry, material colour); the kinematics come from the
sim process, which sends the world placement of each link with a visual in `lab/state`
(`lab.robot.FramePlacements`). Reading them with the standard library keeps the UI process free
of pinocchio, whose geometry loader also decodes every mesh (up to 6 s for Talos); meshes are
decoded by `lab.ui.meshes`, cached.
"""

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from trimesh.transformations import euler_matrix

PACKAGE = "package://"
# Bytes fed to the XML parser at a time: each feed keeps the GIL, and a whole file at once kept
# it for all of it (Talos's 111 KB URDF: 3.5 ms of CPU; a feed 0.5 ms), beside the 1 kHz loop
# in a robot switch's build (lab/runtime/switch.py).
CHUNK = 16 * 1024
DEFAULT_RGBA = (0.9, 0.9, 0.9, 1.0)  # a mesh or shape without a URDF material


@dataclass(frozen=True)
class Visual:
    """One `<visual>` of URDF link `link`.

    `origin` is its 4x4 placement in the link frame; `shape` is "box" (`size` = full extents),
    "cylinder" (radius, length), "sphere" (radius), or "mesh" (`mesh` = file path, `size` = scale);
    `rgba` is the URDF material colour (0..1), None when the visual names no material (a Collada
    mesh then keeps its own colours).
    """

    link: str
    origin: np.ndarray
    shape: str
    size: tuple[float, ...]
    mesh: Path | None = None
    rgba: tuple[float, float, float, float] | None = None


def _floats(text: str | None, default: Sequence[float]) -> tuple[float, ...]:
    return tuple(float(x) for x in text.split()) if text else tuple(default)


def _origin(element: ET.Element | None) -> np.ndarray:
    """The 4x4 transform of an `<origin xyz rpy>` (roll, pitch, yaw about fixed x, y, z)."""
    if element is None:
        return np.eye(4)
    roll, pitch, yaw = _floats(element.get("rpy"), (0.0, 0.0, 0.0))
    transform = euler_matrix(roll, pitch, yaw, "sxyz")
    transform[:3, 3] = _floats(element.get("xyz"), (0.0, 0.0, 0.0))
    return transform


def _resolve(filename: str, package_dirs: Sequence[Path], urdf: Path) -> Path:
    """A mesh path: `package://` under one of `package_dirs`, else relative to the URDF."""
    if filename.startswith(PACKAGE):
        relative = filename.removeprefix(PACKAGE)
        for root in package_dirs:
            if (root / relative).exists():
                return root / relative
        raise FileNotFoundError(f"{urdf.name}: mesh {filename} is under none of {package_dirs}")
    return (
        Path(filename.removeprefix("file://"))
        if filename.startswith("file://")
        else (urdf.parent / filename)
    )


def _rgba(material: ET.Element | None, named: dict[str, tuple[float, ...]]) -> tuple | None:
    """A visual's material colour: a robot-level material of its name wins over its own colour
    (as in urdfdom, pinocchio's parser)."""
    if material is None:
        return None
    if material.get("name", "") in named:
        return named[material.get("name", "")]
    colour = material.find("color")
    return DEFAULT_RGBA if colour is None else _floats(colour.get("rgba"), DEFAULT_RGBA)


def _geometry(geometry: ET.Element) -> tuple[str, tuple[float, ...], str | None]:
    """(shape, size, mesh file name) of a `<geometry>`; raises ValueError for other shapes."""
    box, cylinder, sphere, mesh = (geometry.find(t) for t in ("box", "cylinder", "sphere", "mesh"))
    if box is not None:
        return "box", _floats(box.get("size"), (0.0, 0.0, 0.0)), None
    if cylinder is not None:
        return "cylinder", (float(cylinder.get("radius")), float(cylinder.get("length"))), None
    if sphere is not None:
        return "sphere", (float(sphere.get("radius")),), None
    if mesh is not None:
        return "mesh", _floats(mesh.get("scale"), (1.0, 1.0, 1.0)), mesh.get("filename")
    raise ValueError(f"unsupported visual geometry {[child.tag for child in geometry]}")


def read_visuals(urdf: Path, package_dirs: Sequence[Path]) -> list[Visual]:
    """Every visual of every link of `urdf`, in file order; unsupported shapes are skipped."""
    parser = ET.XMLParser()
    with Path(urdf).open("rb") as file:
        while chunk := file.read(CHUNK):
            parser.feed(chunk)
    root = parser.close()
    named = {
        m.get("name", ""): _floats(m.find("color").get("rgba"), DEFAULT_RGBA)
        for m in root.findall("material")
        if m.find("color") is not None
    }
    visuals = []
    for link in root.findall("link"):
        for element in link.findall("visual"):
            geometry = element.find("geometry")
            try:
                shape, size, filename = _geometry(
                    geometry if geometry is not None else ET.Element("_")
                )
            except ValueError:
                continue
            visuals.append(
                Visual(
                    link=link.get("name", ""),
                    origin=_origin(element.find("origin")),
                    shape=shape,
                    size=size,
                    mesh=None if filename is None else _resolve(filename, package_dirs, urdf),
                    rgba=_rgba(element.find("material"), named),
                )
            )
    return visuals
