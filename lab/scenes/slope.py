"""A straight ramp of ANGLE rising along +x from x = START, then a level plateau.

The ramp is one thin box turned about y; its top surface passes through (START, 0, 0), so the
robot stands on the flat floor behind the foot of the ramp and walks onto it.
"""

import numpy as np

from lab.scenes.flat import flat
from lab.scenes.geometry import TerrainGeom

ANGLE = np.radians(12.0)
START = 0.8  # m, x of the foot of the ramp
LENGTH = 4.0  # m along the ramp surface
WIDTH = 3.0  # m
THICKNESS = 0.1  # m
PLATEAU = 3.0  # m along x


def slope() -> tuple[TerrainGeom, ...]:
    c, s = np.cos(ANGLE), np.sin(ANGLE)
    normal = np.array([-s, 0.0, c])
    middle = np.array([START + 0.5 * LENGTH * c, 0.0, 0.5 * LENGTH * s])
    x, y, z = (float(v) for v in middle - 0.5 * THICKNESS * normal)
    half = -0.5 * ANGLE
    ramp = TerrainGeom(
        "ramp",
        "box",
        (0.5 * LENGTH, 0.5 * WIDTH, 0.5 * THICKNESS),
        (x, y, z),
        (float(np.cos(half)), 0.0, float(np.sin(half)), 0.0),
    )
    top = float(LENGTH * s)
    plateau = TerrainGeom(
        "plateau",
        "box",
        (0.5 * PLATEAU, 0.5 * WIDTH, 0.5 * top),
        (START + LENGTH * float(c) + 0.5 * PLATEAU, 0.0, 0.5 * top),
    )
    return (*flat(), ramp, plateau)
