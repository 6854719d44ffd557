"""The scenes in MuJoCo: terrain geoms on an `MjSpec`'s world body, with their collision bits and
contact priority.

Robot geoms collide with terrain only (contype 1, conaffinity 0: no self-collision); terrain geoms
collide with robot geoms only (contype 0, conaffinity 1). Terrain has contact priority 1, so its
friction (the robot description's coefficient, unless the scene sets its own) decides every
robot-terrain contact.

A moving body (`MovingBody`) is a body of its own with one MuJoCo joint per scene joint, each
tied to its script's target by a joint equality constraint (`eq_data[0]` is the target, set
every step by `ScriptedJoints`) that is switched off where the script lets the body go.
"""

import mujoco
import numpy as np

from lab.scenes import FRICTION_IMPRATIO, scene_bodies, scene_geoms
from lab.scenes.geometry import MovingBody, TerrainGeom

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
    for body in scene_bodies(name):
        add_moving_body(spec, body, friction)
    if name in FRICTION_IMPRATIO:
        spec.option.impratio = FRICTION_IMPRATIO[name]


def add_terrain_geom(
    spec: mujoco.MjSpec,
    geom: TerrainGeom,
    friction: float,
    body: mujoco.MjsBody | None = None,
) -> mujoco.MjsGeom:
    """A geom with terrain collision bits, static on the world body unless `body` is given."""
    added = (body or spec.worldbody).add_geom(
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


# A scene joint's limit is where a body hits the ground (the balance board's lower tilt): stiffer
# than MuJoCo's default (0.02 s time constant), under which the loaded board sank 2° past it.
LIMIT_SOLREF = [0.005, 1.0]
JOINT_TYPES = {"slide": mujoco.mjtJoint.mjJNT_SLIDE, "hinge": mujoco.mjtJoint.mjJNT_HINGE}


def scripted_joint_name(body: str, index: int) -> str:
    """The MuJoCo name of joint `index` of moving body `body` (also its equality's name)."""
    return f"{body}_joint_{index}"


def add_moving_body(spec: mujoco.MjSpec, body: MovingBody, friction: float) -> None:
    """`body` on the world body: its joints (held to the script by joint equalities) and geoms."""
    added = spec.worldbody.add_body(name=body.name, pos=list(body.position))
    added.mass = body.mass
    added.ipos = list(body.com)
    added.inertia = list(body.inertia)
    added.explicitinertial = True
    for k, joint in enumerate(body.joints):
        name = scripted_joint_name(body.name, k)
        j = added.add_joint(name=name, type=JOINT_TYPES[joint.kind], axis=list(joint.axis))
        if joint.range is not None:
            j.range = list(joint.range)
            j.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            j.solref_limit = LIMIT_SOLREF
        spec.add_equality(
            name=name, type=mujoco.mjtEq.mjEQ_JOINT, name1=name, objtype=mujoco.mjtObj.mjOBJ_JOINT
        )
    for geom in body.geoms:
        add_terrain_geom(spec, geom, friction, added)


class ScriptedJoints:
    """The moving bodies of a compiled scene, driven by their scripts: `apply(t)` sets every
    joint equality's target to the script's value at sim time t (the script read t − `start`
    seconds in), or switches it off.

    A script's clock starts at the last `reset`: a reset at any sim time (the session's, or one
    at the time a diverged simulation stopped) puts the bodies back at their scripts' start, so
    the robot is set down on terrain that is held, as at the first start. (Scripts read sim time
    before: a reset after the balance board's drop put the robot on a level board its script had
    already let go, which then fell to its limit with the robot on it.)"""

    def __init__(self, model: mujoco.MjModel, bodies: tuple[MovingBody, ...]) -> None:
        self.bodies = bodies
        self.start = 0.0  # s, the sim time of the last reset: the scripts' zero
        names = [[scripted_joint_name(b.name, k) for k in range(len(b.joints))] for b in bodies]
        self._eq = [np.array([model.equality(n).id for n in body]) for body in names]
        self.body_ids = [model.body(b.name).id for b in bodies]
        self._qpos = [np.array([model.joint(n).qposadr[0] for n in body]) for body in names]

    def reset(self, model: mujoco.MjModel, data: mujoco.MjData, t: float) -> None:
        """Restart every script at sim time t: each body where its script starts (at rest),
        before `mj_forward`; a body whose script starts let go stays where `mj_resetData` put
        it."""
        self.start = t
        for body, qpos in zip(self.bodies, self._qpos, strict=True):
            targets = body.script(0.0)
            if targets is not None:
                data.qpos[qpos] = targets
        self.apply(model, data, t)

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData, t: float) -> None:
        """Before a step at sim time t: each joint equality's target from its script (at
        t − the last reset's time), or off."""
        for body, eq in zip(self.bodies, self._eq, strict=True):
            targets = body.script(t - self.start)
            if targets is None:
                data.eq_active[eq] = 0
            else:
                data.eq_active[eq] = 1
                model.eq_data[eq, 0] = targets

    def poses(self, data: mujoco.MjData) -> dict[str, list[float]]:
        """Each moving body's world pose: [x, y, z, qw, qx, qy, qz]."""
        return {
            b.name: [*data.xpos[i].tolist(), *data.xquat[i].tolist()]
            for b, i in zip(self.bodies, self.body_ids, strict=True)
        }
