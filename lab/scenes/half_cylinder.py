"""A half cylinder lying along x (Hutter 2014 Exp8): feet stand on its two slopes.

The geometry is `lab.controller.surfaces.HALF_CYLINDER`, so the controller knows the surface
normals exactly. The cylinder's lower half is under a floor at its axis height. Its surface is
smoother than the robot's usual ground: FRICTION instead of the description's coefficient, so
that forces not aligned with the surface normals make the feet slip.
"""

import numpy as np

from lab.controller.surfaces import HALF_CYLINDER
from lab.scenes.geometry import TerrainGeom

FRICTION = 0.5
HALF_LENGTH = 1.5  # m along x


def half_cylinder() -> tuple[TerrainGeom, ...]:
    axis = (0.0, 0.0, HALF_CYLINDER.axis_height)
    c = float(np.sqrt(0.5))
    return (
        TerrainGeom("floor", "plane", (0.0, 0.0, 1.0), axis, friction=FRICTION),
        TerrainGeom(
            "half_cylinder",
            "cylinder",
            (HALF_CYLINDER.radius, HALF_LENGTH, 0.0),
            axis,
            (c, 0.0, c, 0.0),  # the cylinder's z axis along world x
            friction=FRICTION,
        ),
    )
