"""A static shape of a scene's terrain, as plain data (no MuJoCo): the sim builds its world from
it (`lab.scenes.terrain`) and the browser draws it (`lab.ui.terrain_view`)."""

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
