"""Rough ground: a seeded field of square tiles whose tops are a few centimetres high.

The tiles start a little ahead of the robot's standing place (x = START) so that it starts on
flat ground, and cover LENGTH x WIDTH metres; each tile's top height is drawn uniformly from
[0, MAX_HEIGHT] by a generator seeded with SEED, so the terrain is the same in every run. Box
geoms (not a height field) so that the browser draws them like any other terrain.
"""

import mujoco
import numpy as np

from lab.scenes.flat import flat
from lab.scenes.terrain import add_terrain_geom

SEED = 5
START = 0.6  # m, x of the first row of tiles
LENGTH = 12.0  # m along x
WIDTH = 3.0  # m along y, centred on y = 0
TILE = 0.3  # m, side of a tile
MAX_HEIGHT = 0.04  # m
DEPTH = 0.05  # m, tiles reach this far below the floor


def rough(spec: mujoco.MjSpec, friction: float) -> None:
    flat(spec, friction)
    rng = np.random.default_rng(SEED)
    nx, ny = round(LENGTH / TILE), round(WIDTH / TILE)
    heights = rng.uniform(0.0, MAX_HEIGHT, size=(nx, ny))
    for i in range(nx):
        for j in range(ny):
            top = heights[i, j]
            add_terrain_geom(
                spec,
                friction,
                name=f"tile_{i}_{j}",
                type=mujoco.mjtGeom.mjGEOM_BOX,
                size=[0.5 * TILE, 0.5 * TILE, 0.5 * (top + DEPTH)],
                pos=[START + (i + 0.5) * TILE, (j + 0.5) * TILE - 0.5 * WIDTH, 0.5 * (top - DEPTH)],
            )
