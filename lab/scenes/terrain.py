"""The scenes in MuJoCo: terrain geoms on an `MjSpec`'s world body, with their collision bits and
contact priority.

Robot geoms collide with terrain only (contype 1, conaffinity 0: no self-collision); terrain geoms
collide with robot geoms only (contype 0, conaffinity 1). Terrain has contact priority 1, so its
friction (the robot description's coefficient, unless the scene sets its own) decides every
robot-terrain contact.
"""

import mujoco

from lab.scenes import FRICTION_IMPRATIO, scene_geoms
from lab.scenes.geometry import TerrainGeom

ROBOT_CONTYPE = 1
ROBOT_CONAFFINITY = 0
GEOM_TYPES = {
    "plane": mujoco.mjtGeom.mjGEOM_PLANE,
    "box": mujoco.mjtGeom.mjGEOM_BOX,
    "cylinder": mujoco.mjtGeom.mjGEOM_CYLINDER,
    "sphere": mujoco.mjtGeom.mjGEOM_SPHERE,
}


def add_scene(spec: mujoco.MjSpec, name: str, friction: float, seed: int | None = None) -> None:
    """Add scene `name` to `spec` (its random terrain drawn with `seed`, see `scene_geoms`),
    `friction` for geoms that set none; an unknown name raises KeyError naming the known
    scenes."""
    for geom in scene_geoms(name, seed):
        add_terrain_geom(spec, geom, friction)
    if name in FRICTION_IMPRATIO:
        spec.option.impratio = FRICTION_IMPRATIO[name]


def add_terrain_geom(spec: mujoco.MjSpec, geom: TerrainGeom, friction: float) -> mujoco.MjsGeom:
    """A static geom on the world body with terrain collision bits."""
    added = spec.worldbody.add_geom(
        name=geom.name,
        type=GEOM_TYPES[geom.shape],
        size=list(geom.size),
        pos=list(geom.position),
        quat=list(geom.wxyz),
    )
    added.contype = 0
    added.conaffinity = 1
    added.priority = 1
    added.friction = [friction if geom.friction is None else geom.friction, 0.005, 0.0001]
    return added
