"""The worlds the robot stands in, as plain geometry (this package imports no MuJoCo but
`terrain.py`).

A scene is a function `() -> tuple[TerrainGeom, ...]` registered in `SCENES`: the static terrain
shapes; a scene whose terrain moves also has its `MovingBody`s in `MOVING_BODIES`.
`lab.scenes.terrain.add_scene` adds them to a MuJoCo `MjSpec` for the sim; the browser UI
draws the same list, so what is drawn is what is simulated.
"""

from collections.abc import Callable

from lab.scenes.balance_board import (
    balance_board,
    balance_board_bodies,
    balance_board_lateral_bodies,
)
from lab.scenes.block import HEIGHT as BLOCK_HEIGHT
from lab.scenes.block import block
from lab.scenes.flat import flat
from lab.scenes.geometry import MovingBody, TerrainGeom
from lab.scenes.half_cylinder import half_cylinder
from lab.scenes.platform import platform, platform_bodies
from lab.scenes.rough import rough
from lab.scenes.slope import slope
from lab.scenes.split_wedges import split_wedges

Scene = Callable[[], tuple[TerrainGeom, ...]]

SCENES: dict[str, Scene] = {
    "flat": flat,
    "half_cylinder": half_cylinder,
    "rough": rough,
    "slope": slope,
    "split_wedges": split_wedges,
    "block": block,
    "platform": platform,
    "balance_board": balance_board,
    "balance_board_lateral": balance_board,
}

# Scenes with terrain that moves (Herzog 2016 §5.2.3): their moving bodies, besides the static
# geoms of SCENES.
MOVING_BODIES: dict[str, Callable[[], tuple[MovingBody, ...]]] = {
    "platform": platform_bodies,
    "balance_board": balance_board_bodies,
    "balance_board_lateral": balance_board_lateral_bodies,
}

# Scenes made for some robots' feet only: a session refuses them for other robots.
SCENE_ROBOTS: dict[str, tuple[str, ...]] = {"block": ("talos",)}

# Scenes where the robot starts with one foot raised: (contact name, rise in m).
START_RISE: dict[str, tuple[str, float]] = {"block": ("left", BLOCK_HEIGHT)}

# Scenes where feet stand on slopes held by friction alone: MuJoCo's friction is made this much
# stiffer than the normal direction (`impratio`; 1 elsewhere). Under the default soft friction a
# foot on split_wedges' 45° faces creeps down at 1 cm/s inside the friction cone (0.7 mm/s here).
FRICTION_IMPRATIO: dict[str, float] = {"split_wedges": 10.0}


# Scenes with random terrain: their generator takes a seed (a scenario's `terrain_seed`).
SEEDED_SCENES: dict[str, Callable[[int], tuple[TerrainGeom, ...]]] = {"rough": rough}


def scene_geoms(name: str, seed: int | None = None) -> tuple[TerrainGeom, ...]:
    """The terrain of scene `name`, its random terrain drawn with `seed` (None: the scene's
    own; scenes without random terrain have nothing to seed); an unknown name raises KeyError
    naming the known scenes."""
    if name not in SCENES:
        raise KeyError(f"unknown scene {name!r}; known scenes: {', '.join(sorted(SCENES))}")
    if seed is not None and name in SEEDED_SCENES:
        return SEEDED_SCENES[name](seed)
    return SCENES[name]()


def scene_bodies(name: str) -> tuple[MovingBody, ...]:
    """The moving bodies of scene `name` (none for a static scene)."""
    return MOVING_BODIES[name]() if name in MOVING_BODIES else ()
