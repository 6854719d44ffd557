"""A half cylinder lying along x (Hutter 2014 Exp8): feet stand on its two slopes.

The geometry is `lab.controller.surfaces.HALF_CYLINDER`, so the controller knows the surface
normals exactly. The cylinder's lower half is under a floor at its axis height. Its surface is
smoother than the robot's usual ground: FRICTION instead of the description's coefficient, so
that forces not aligned with the surface normals make the feet slip.
"""

import mujoco
import numpy as np

from lab.controller.surfaces import HALF_CYLINDER
from lab.scenes.terrain import add_terrain_geom

FRICTION = 0.5
HALF_LENGTH = 1.5  # m along x


def half_cylinder(spec: mujoco.MjSpec, friction: float) -> None:
    add_terrain_geom(
        spec,
        FRICTION,
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[0.0, 0.0, 1.0],
        pos=[0.0, 0.0, HALF_CYLINDER.axis_height],
    )
    c = np.sqrt(0.5)
    add_terrain_geom(
        spec,
        FRICTION,
        name="half_cylinder",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[HALF_CYLINDER.radius, HALF_LENGTH, 0.0],
        pos=[0.0, 0.0, HALF_CYLINDER.axis_height],
        quat=[c, 0.0, c, 0.0],  # the cylinder's z axis along world x
    )
