"""What every terrain geom shares: collision bits and contact priority.

Robot geoms collide with terrain only (contype 1, conaffinity 0: no self-collision); terrain geoms
collide with robot geoms only (contype 0, conaffinity 1). Terrain has contact priority 1, so its
friction (the robot description's coefficient) decides every robot-terrain contact.
"""

import mujoco

ROBOT_CONTYPE = 1
ROBOT_CONAFFINITY = 0


def add_terrain_geom(spec: mujoco.MjSpec, friction: float, **attributes) -> mujoco.MjsGeom:
    """A static geom on the world body with terrain collision bits and the given friction."""
    geom = spec.worldbody.add_geom(**attributes)
    geom.contype = 0
    geom.conaffinity = 1
    geom.priority = 1
    geom.friction = [friction, 0.005, 0.0001]
    return geom
