"""MuJoCo worlds the robot stands in.

A scene is one function `(spec, friction) -> None` that adds static terrain geoms to the world body
of an `MjSpec`; register it in `SCENES`. Terrain geoms use `TERRAIN` collision bits and win the
contact-parameter priority, so the friction coefficient given here is the one every contact uses.
"""

from collections.abc import Callable

import mujoco

from lab.scenes.flat import flat
from lab.scenes.half_cylinder import half_cylinder
from lab.scenes.rough import rough
from lab.scenes.slope import slope

Scene = Callable[[mujoco.MjSpec, float], None]

SCENES: dict[str, Scene] = {
    "flat": flat,
    "half_cylinder": half_cylinder,
    "rough": rough,
    "slope": slope,
}


def add_scene(spec: mujoco.MjSpec, name: str, friction: float) -> None:
    """Add scene `name` to `spec`; an unknown name raises KeyError naming the known scenes."""
    if name not in SCENES:
        raise KeyError(f"unknown scene {name!r}; known scenes: {', '.join(sorted(SCENES))}")
    SCENES[name](spec, friction)
