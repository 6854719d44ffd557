"""A straight ramp of ANGLE rising along +x from x = START, then a level plateau.

The ramp is one thin box turned about y; its top surface passes through (START, 0, 0), so the
robot stands on the flat floor behind the foot of the ramp and walks onto it.
"""

import mujoco
import numpy as np

from lab.scenes.flat import flat
from lab.scenes.terrain import add_terrain_geom

ANGLE = np.radians(12.0)
START = 0.8  # m, x of the foot of the ramp
LENGTH = 4.0  # m along the ramp surface
WIDTH = 3.0  # m
THICKNESS = 0.1  # m
PLATEAU = 3.0  # m along x


def slope(spec: mujoco.MjSpec, friction: float) -> None:
    flat(spec, friction)
    c, s = np.cos(ANGLE), np.sin(ANGLE)
    normal = np.array([-s, 0.0, c])
    middle = np.array([START + 0.5 * LENGTH * c, 0.0, 0.5 * LENGTH * s])
    add_terrain_geom(
        spec,
        friction,
        name="ramp",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.5 * LENGTH, 0.5 * WIDTH, 0.5 * THICKNESS],
        pos=middle - 0.5 * THICKNESS * normal,
        quat=[np.cos(-0.5 * ANGLE), 0.0, np.sin(-0.5 * ANGLE), 0.0],  # MuJoCo (w, x, y, z)
    )
    top = LENGTH * s
    add_terrain_geom(
        spec,
        friction,
        name="plateau",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.5 * PLATEAU, 0.5 * WIDTH, 0.5 * top],
        pos=[START + LENGTH * c + 0.5 * PLATEAU, 0.0, 0.5 * top],
    )
