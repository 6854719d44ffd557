"""A flat floor at z = 0."""

import mujoco

from lab.scenes.terrain import add_terrain_geom


def flat(spec: mujoco.MjSpec, friction: float) -> None:
    add_terrain_geom(
        spec, friction, name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.0, 0.0, 1.0]
    )
