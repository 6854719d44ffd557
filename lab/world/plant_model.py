"""The plant's MuJoCo model: the robot's URDF, its motors and the scene in one `MjSpec`.

`build_spec` loads the robot's URDF into an `MjSpec` (the same file pinocchio reads), welds the
locked joints at their reference angle, adds a free joint, one torque motor per actuated joint and
the scene; `shorten_shanks` and `mute_shank_meshes` trim, in the compiled model, the geometry
that would touch the ground beside a foot. `MujocoPlant` (plant.py) runs the result.

Physics choices (documented in the report of issue 2):
- URDF joint damping, friction and armature are zeroed, and inertias are taken from the URDF only
  (never from geoms), so MuJoCo's rigid-body dynamics equal pinocchio's.
- Static (fixed-joint) bodies are fused into their parent, which also merges dummy inertia links
  such as ANYmal's massless `base` + `base_inertia` into one valid body.
- Visual geometry is dropped (the browser draws meshes itself). Collision geometry is kept for fall
  detection: primitives as they are, STL meshes by file, Collada meshes (HyQ) converted with
  trimesh. The collision geometry of each foot link is replaced by the contact shape: a sphere of
  the contact radius centred on the contact frame, or a box whose bottom face is the sole
  rectangle. Self-collision is off (robot geoms only collide with terrain), so overlapping URDF
  boxes (ANYmal's base and thighs) never fight.
- Timestep 1 ms, `implicitfast` integrator (semi-implicit Euler for the rigid body here, since no
  joint damping is modelled, and it stays stable if damping or velocity-dependent actuators are
  added), Newton solver with elliptic friction cones (the physical cone; the controller uses an
  inner pyramid of it), default soft-contact parameters: stable standing under torque control with
  millimetre penetration.
- MuJoCo's automatic reset on a bad state (`mjDSBL_AUTORESET`) is off: it would silently put the
  robot at the model's origin and the clock at 0 (the plant checks the state instead).
"""

import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin
import trimesh

from lab.robot import Robot
from lab.scenes.terrain import ROBOT_CONAFFINITY, ROBOT_CONTYPE, add_scene

SOLE_HALF_THICKNESS = 0.01  # m, half height of the box that stands for a flat foot


def _resolve(filename: str, urdf_dir: Path, package_dirs: tuple[Path, ...]) -> Path:
    if filename.startswith("package://"):
        relative = filename.removeprefix("package://")
        for root in package_dirs:
            if (root / relative).is_file():
                return root / relative
        raise FileNotFoundError(f"mesh {filename} not found under {package_dirs}")
    return urdf_dir / filename


def _attribute(element: ET.Element, name: str) -> str:
    """URDF attribute `name` of `element`; ValueError naming both when it is missing."""
    value = element.get(name)
    if value is None:
        raise ValueError(f"URDF <{element.tag}> has no attribute {name!r}")
    return value


def _origin(element: ET.Element | None) -> tuple[np.ndarray, np.ndarray]:
    """URDF <origin> as (position, MuJoCo quaternion w, x, y, z)."""
    xyz = np.zeros(3)
    rpy = np.zeros(3)
    if element is not None:
        xyz = np.array([float(x) for x in element.get("xyz", "0 0 0").split()])
        rpy = np.array([float(x) for x in element.get("rpy", "0 0 0").split()])
    x, y, z, w = pin.Quaternion(pin.rpy.rpyToMatrix(rpy)).coeffs()
    return xyz, np.array([w, x, y, z])


def _strip_geometry(urdf: ET.Element) -> dict[str, list[ET.Element]]:
    """Remove visual and collision elements; return the collision elements by link name."""
    collisions: dict[str, list[ET.Element]] = {}
    for link in urdf.findall("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
        name = _attribute(link, "name")
        collisions[name] = link.findall("collision")
        for collision in collisions[name]:
            link.remove(collision)
    return collisions


def _add_collision(
    spec: mujoco.MjSpec,
    body: mujoco.MjsBody,
    collision: ET.Element,
    urdf_dir: Path,
    package_dirs: tuple[Path, ...],
) -> None:
    pos, quat = _origin(collision.find("origin"))
    geometry = collision.find("geometry")
    if geometry is None or not len(geometry):
        raise ValueError("URDF <collision> without a <geometry> shape")
    shape = geometry[0]
    geom = body.add_geom(pos=pos, quat=quat)
    if shape.tag == "box":
        geom.type = mujoco.mjtGeom.mjGEOM_BOX
        geom.size = [0.5 * float(s) for s in _attribute(shape, "size").split()]
    elif shape.tag == "cylinder":
        geom.type = mujoco.mjtGeom.mjGEOM_CYLINDER
        radius, length = float(_attribute(shape, "radius")), float(_attribute(shape, "length"))
        geom.size = [radius, 0.5 * length, 0.0]
    elif shape.tag == "sphere":
        geom.type = mujoco.mjtGeom.mjGEOM_SPHERE
        geom.size = [float(_attribute(shape, "radius")), 0.0, 0.0]
    elif shape.tag == "mesh":
        path = _resolve(_attribute(shape, "filename"), urdf_dir, package_dirs)
        scale = [float(s) for s in shape.get("scale", "1 1 1").split()]
        name = f"{path.stem}_{len(spec.meshes)}"
        if path.suffix.lower() == ".stl":
            spec.add_mesh(name=name, file=str(path), scale=scale)
        else:  # Collada (HyQ) and others MuJoCo cannot decode: convert with trimesh
            mesh = trimesh.load(path, force="mesh")
            assert isinstance(mesh, trimesh.Trimesh)  # force="mesh" merges a scene into one
            spec.add_mesh(
                name=name,
                uservert=(np.asarray(mesh.vertices) * scale).ravel().tolist(),
                userface=np.asarray(mesh.faces).ravel().tolist(),
            )
        geom.type = mujoco.mjtGeom.mjGEOM_MESH
        geom.meshname = name
    else:
        raise ValueError(f"unsupported URDF collision geometry <{shape.tag}>")


def _weld(spec: mujoco.MjSpec, joint: mujoco.MjsJoint, angle: float) -> None:
    """Turn `joint` (a hinge) into a weld at `angle`: rotate its body and delete the joint."""
    body = joint.parent
    turn = np.zeros(4)
    mujoco.mju_axisAngle2Quat(turn, np.asarray(joint.axis, dtype=float), angle)
    if np.linalg.norm(joint.pos) > 0.0:
        raise ValueError(f"cannot weld joint {joint.name!r}: its axis is off the body origin")
    quat = np.zeros(4)
    mujoco.mju_mulQuat(quat, np.asarray(body.quat, dtype=float), turn)
    body.quat = quat
    spec.delete(joint)


def _placement(body: mujoco.MjsBody) -> pin.SE3:
    """Pose of `body` in its parent body."""
    w, x, y, z = body.quat
    return pin.SE3(pin.Quaternion(w, x, y, z).normalized().matrix(), np.asarray(body.pos, float))


def _inertia(body: mujoco.MjsBody) -> pin.Inertia:
    """Spatial inertia of `body` alone, in its frame (URDF data as parsed by MuJoCo)."""
    if np.isnan(body.ipos[0]):  # no <inertial>
        return pin.Inertia.Zero()
    if np.isnan(body.fullinertia[0]):  # principal moments in the `iquat` frame
        about_com = np.diag(body.inertia)
    else:
        xx, yy, zz, xy, xz, yz = body.fullinertia
        about_com = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    w, x, y, z = body.iquat
    rotation = pin.Quaternion(w, x, y, z).normalized().matrix()
    rotated = rotation @ about_com @ rotation.T
    return pin.Inertia(body.mass, np.asarray(body.ipos, float), 0.5 * (rotated + rotated.T))


def _fold_static_inertias(spec: mujoco.MjSpec) -> None:
    """Move the inertia of every jointless body into its nearest moving ancestor.

    This is how pinocchio builds its bodies from fixed URDF links; done before compiling, it also
    removes the degenerate inertias MuJoCo rejects on fixed links (ANYmal's cameras, Talos' wrist
    sensors, HyQ's massless base link) without changing total mass or centre of mass.
    """
    totals: dict[str, tuple[mujoco.MjsBody, pin.Inertia]] = {}
    for body in spec.bodies:
        if body.name == "world":
            continue
        anchor, placement = body, pin.SE3.Identity()
        while not anchor.joints:
            placement = _placement(anchor) * placement
            anchor = anchor.parent
        moving, total = totals.get(anchor.name, (anchor, pin.Inertia.Zero()))
        totals[anchor.name] = (moving, total + placement.act(_inertia(body)))
        if body is not anchor:
            body.mass = 0.0
            body.fullinertia = [np.nan, 0.0, 0.0, 0.0, 0.0, 0.0]  # unset: no inertial
            body.explicitinertial = False
    for body, total in totals.values():
        inertia = total.inertia
        body.mass = total.mass
        body.ipos = total.lever
        body.iquat = [1.0, 0.0, 0.0, 0.0]
        body.fullinertia = [*np.diag(inertia), inertia[0, 1], inertia[0, 2], inertia[1, 2]]


def build_spec(
    robot: Robot, scene: str, timestep: float, terrain_seed: int | None = None
) -> mujoco.MjSpec:
    """The MuJoCo world: robot from its URDF (see module docstring), motors and scene (its
    random terrain drawn with `terrain_seed`, lab.scenes.scene_geoms)."""
    desc = robot.description
    urdf = ET.parse(desc.urdf_path).getroot()
    collisions = _strip_geometry(urdf)
    spec = mujoco.MjSpec.from_string(ET.tostring(urdf, encoding="unicode"))
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.compiler.balanceinertia = False
    spec.compiler.fusestatic = True
    spec.compiler.discardvisual = True
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET

    for name, angle in robot.locked_positions.items():
        _weld(spec, spec.joint(name), angle)
    for joint in spec.joints:
        joint.damping = [0.0, 0.0, 0.0]
        joint.frictionloss = 0.0
        joint.armature = 0.0
        joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_FALSE
    root = spec.worldbody.first_body()
    root.add_freejoint(name="root_joint")
    _fold_static_inertias(spec)

    foot_links = set(robot.foot_links)
    for link, elements in collisions.items():
        if link in foot_links:
            continue
        for collision in elements:
            _add_collision(
                spec, spec.body(link), collision, desc.urdf_path.parent, desc.package_dirs
            )
    for contact, link, offset in zip(
        robot.contacts, robot.foot_links, robot.foot_offsets, strict=True
    ):
        body = spec.body(link)
        body.add_site(name=contact.name, pos=offset)
        if contact.kind == "point":
            body.add_geom(
                name=contact.name,
                type=mujoco.mjtGeom.mjGEOM_SPHERE,
                size=[contact.radius, 0, 0],
                pos=offset,
            )
        else:
            body.add_geom(
                name=contact.name,
                type=mujoco.mjtGeom.mjGEOM_BOX,
                size=[contact.half_length, contact.half_width, SOLE_HALF_THICKNESS],
                pos=[offset[0], offset[1], offset[2] + SOLE_HALF_THICKNESS],
            )
    for geom in spec.geoms:
        geom.contype = ROBOT_CONTYPE
        geom.conaffinity = ROBOT_CONAFFINITY

    for name, limit in zip(robot.joint_names, robot.torque_limits, strict=True):
        spec.add_actuator(
            name=name,
            target=name,
            trntype=mujoco.mjtTrn.mjTRN_JOINT,
            ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE,
            ctrlrange=[-limit, limit],
        )
    add_scene(spec, scene, desc.friction, terrain_seed)
    return spec


ROUND_SHANKS = (int(mujoco.mjtGeom.mjGEOM_CYLINDER), int(mujoco.mjtGeom.mjGEOM_CAPSULE))


def shorten_shanks(m: mujoco.MjModel, foot_geoms: np.ndarray) -> None:
    """End each cylinder or capsule of a foot's body one foot radius before the foot centre.

    HyQ's shank cylinder runs exactly to the foot-sphere centre: with the few millimetres a soft
    contact sinks, its rim touched the floor in stance and counted as a fall. Only geometry that
    overlaps the foot sphere is trimmed; the robot's mass and inertia do not come from geoms.
    """
    for foot in foot_geoms:
        body, centre, radius = m.geom_bodyid[foot], m.geom_pos[foot], m.geom_size[foot][0]
        for g in np.flatnonzero(m.geom_bodyid == body):
            if g == foot or m.geom_type[g] not in ROUND_SHANKS:
                continue
            axis = np.zeros(9)
            mujoco.mju_quat2Mat(axis, m.geom_quat[g])
            axis = axis.reshape(3, 3)[:, 2]
            half = m.geom_size[g][1]
            offset = centre - m.geom_pos[g]
            along = float(axis @ offset)  # foot centre along the axis
            across = float(np.linalg.norm(offset - along * axis))  # and away from it
            end = np.sign(along) * half
            reach = radius - (abs(along) - half)  # how far the end pokes into the sphere
            if reach > 0.0 and across < m.geom_size[g][0] + radius:
                cut = min(reach, half)
                m.geom_size[g][1] = half - cut / 2
                m.geom_pos[g] -= np.sign(end) * axis * cut / 2


def mute_shank_meshes(m: mujoco.MjModel, foot_geoms: np.ndarray) -> None:
    """Take out of collision each mesh of a point foot's body that reaches into the foot sphere.

    Bolt's shank mesh ends in the foot: its hull's rim touched the floor whenever a stance leg
    leaned (stepping sideways), and counted as a fall. The foot sphere stays the contact; the
    robot's mass and inertia do not come from geoms.
    """
    for foot in foot_geoms:
        if m.geom_type[foot] != mujoco.mjtGeom.mjGEOM_SPHERE:
            continue
        body, centre, radius = m.geom_bodyid[foot], m.geom_pos[foot], m.geom_size[foot][0]
        for g in np.flatnonzero(m.geom_bodyid == body):
            mesh = m.geom_dataid[g]
            if g == foot or m.geom_type[g] != mujoco.mjtGeom.mjGEOM_MESH or mesh < 0:
                continue
            rotation = np.zeros(9)
            mujoco.mju_quat2Mat(rotation, m.geom_quat[g])
            start, count = m.mesh_vertadr[mesh], m.mesh_vertnum[mesh]
            vertices = m.mesh_vert[start : start + count] @ rotation.reshape(3, 3).T
            if np.min(np.linalg.norm(vertices + m.geom_pos[g] - centre, axis=1)) < radius:
                m.geom_contype[g] = m.geom_conaffinity[g] = 0
