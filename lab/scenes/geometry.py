"""A shape of a scene's terrain, as plain data (no MuJoCo): the sim builds its world from it
(`lab.scenes.terrain`) and the browser draws it (`lab.ui.terrain_view`). Static shapes are
`TerrainGeom`s; a `MovingBody` carries shapes that a script moves (a platform, a tilting board)."""

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

Shape = Literal["plane", "box", "cylinder", "sphere"]


@dataclass(frozen=True)
class TerrainGeom:
    """One terrain shape, sized as MuJoCo sizes it (m): plane (half x, half y, grid spacing; a
    zero half size is an infinite plane), box (half x, y, z), cylinder (radius, half length
    along its z axis), sphere (radius). `position` in the world, `wxyz` the orientation as a
    quaternion (w, x, y, z); `friction` replaces the robot description's coefficient."""

    name: str
    shape: Shape
    size: tuple[float, float, float]
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    friction: float | None = None


@dataclass(frozen=True)
class SceneJoint:
    """A joint of a moving scene body: a `slide` (m) or `hinge` (rad) along/about `axis` (body
    frame, through its origin), with an optional `range` the sim enforces as a joint limit."""

    kind: Literal["slide", "hinge"]
    axis: tuple[float, float, float]
    range: tuple[float, float] | None = None


@dataclass(frozen=True)
class MovingBody:
    """A terrain body that moves: `geoms` (placed in the body frame) on a body at `position`
    (world, at rest), whose `joints` are applied in order. `script(t)` gives the joints' targets
    t seconds after the sim's last reset (its start), which the sim holds each joint to (a soft
    equality constraint), or None where the body moves freely from then on (under gravity,
    contact and joint limits). `mass` (kg), `inertia` (principal moments about the centre of
    mass, kg m², body axes) and `com` (centre of mass, body frame) are the body's."""

    name: str
    position: tuple[float, float, float]
    geoms: tuple[TerrainGeom, ...]
    joints: tuple[SceneJoint, ...]
    script: Callable[[float], tuple[float, ...] | None]
    mass: float
    inertia: tuple[float, float, float]
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)


def box_inertia(mass: float, half: tuple[float, float, float]) -> tuple[float, float, float]:
    """Principal moments of inertia (kg m²) of a solid box of `mass` and half sizes `half`."""
    x, y, z = (4.0 * h * h for h in half)
    return (mass * (y + z) / 12, mass * (x + z) / 12, mass * (x + y) / 12)
