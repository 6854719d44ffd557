"""Rough ground: a seeded field of square tiles whose tops are a few centimetres high.

The tiles start a little ahead of the robot's standing place (x = START) so that it starts on
flat ground, and cover LENGTH x WIDTH metres; each tile's top height is drawn uniformly from
[0, MAX_HEIGHT] by a generator seeded with `seed` (SEED unless a scenario's `terrain_seed` says
otherwise), so the terrain is the same in every run with that seed. Box geoms (not a height
field) so that the browser draws them like any other terrain.
"""

import numpy as np

from lab.scenes.flat import flat
from lab.scenes.geometry import TerrainGeom

SEED = 5
START = 0.6  # m, x of the first row of tiles
LENGTH = 12.0  # m along x
WIDTH = 3.0  # m along y, centred on y = 0
TILE = 0.3  # m, side of a tile
MAX_HEIGHT = 0.04  # m
DEPTH = 0.05  # m, tiles reach this far below the floor


def rough(seed: int = SEED) -> tuple[TerrainGeom, ...]:
    rng = np.random.default_rng(seed)
    nx, ny = round(LENGTH / TILE), round(WIDTH / TILE)
    heights = rng.uniform(0.0, MAX_HEIGHT, size=(nx, ny))
    tiles = []
    for i in range(nx):
        for j in range(ny):
            top = float(heights[i, j])
            tiles.append(
                TerrainGeom(
                    f"tile_{i}_{j}",
                    "box",
                    (0.5 * TILE, 0.5 * TILE, 0.5 * (top + DEPTH)),
                    (START + (i + 0.5) * TILE, (j + 0.5) * TILE - 0.5 * WIDTH, 0.5 * (top - DEPTH)),
                )
            )
    return (*flat(), *tiles)
