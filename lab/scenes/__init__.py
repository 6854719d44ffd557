"""The worlds the robot stands in, as plain geometry (this package imports no MuJoCo but
`terrain.py`).

A scene is a function `() -> tuple[TerrainGeom, ...]` registered in `SCENES`: the static terrain
shapes. `lab.scenes.terrain.add_scene` adds them to a MuJoCo `MjSpec` for the sim; the browser UI
draws the same list, so what is drawn is what is simulated.
"""

from collections.abc import Callable

from lab.scenes.flat import flat
from lab.scenes.geometry import TerrainGeom
from lab.scenes.half_cylinder import half_cylinder
from lab.scenes.rough import rough
from lab.scenes.slope import slope

Scene = Callable[[], tuple[TerrainGeom, ...]]

SCENES: dict[str, Scene] = {
    "flat": flat,
    "half_cylinder": half_cylinder,
    "rough": rough,
    "slope": slope,
}


def scene_geoms(name: str) -> tuple[TerrainGeom, ...]:
    """The terrain of scene `name`; an unknown name raises KeyError naming the known scenes."""
    if name not in SCENES:
        raise KeyError(f"unknown scene {name!r}; known scenes: {', '.join(sorted(SCENES))}")
    return SCENES[name]()
