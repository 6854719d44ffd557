"""The MuJoCo world of one robot, spoken to in pinocchio conventions.

`MujocoPlant` runs the model `plant_model.py` builds from the robot's URDF (the same file
pinocchio reads) and the scene, and is the only place that converts between the engines:

- q = [base position (world), quaternion (x, y, z, w), joints in pinocchio order]
  vs MuJoCo qpos = [position, quaternion (w, x, y, z), joints in MuJoCo order];
- v = [base linear velocity (base frame), angular velocity (base frame), joint velocities]
  vs MuJoCo qvel = [linear velocity (world frame), angular velocity (body frame), joints];
- joints are matched by name (ANYmal's order differs between the engines).

What it measures (touch, foot forces, centres of pressure, the terrain's poses) is
`plant_sensing.py`'s `PlantSensing`, which it derives from (this file, a little over 400 lines,
is the running world alone: state in and out, step and check, pushes, drives and payloads).
Running choices:
- MuJoCo's automatic reset on a bad state is off (plant_model.py): `step()` instead raises
  `SimulationDiverged` (MuJoCo's bad position / velocity / acceleration warnings, or a
  non-finite state) and the caller decides what state comes next (the session:
  docs/architecture.md, "Faults").
- A scene's moving terrain (a rolling platform, a balance board: `lab.scenes.terrain`) is
  driven by its script before every step (`moving_terrain`); its joints come after the robot's
  in qpos and qvel. Terrain is every geom not on the robot's body tree.
- The per-tick calls (`check`, `state`, `set_torques`, `step`, touch sensing) cross once each
  into `lab._plant` (cpp/plant/plant.cpp, MuJoCo's C API on this plant's MjModel and MjData)
  when it is built; the Python code below is the reference and runs otherwise.
- Joint damping is 0 (the controller's model has none) unless the caller sets it with
  `set_joint_damping`: the session damps the limp joints of a fallen robot. `implicitfast`
  integrates it implicitly, so any damping is stable.
"""

import math

import mujoco
import numpy as np
import pinocchio as pin

from lab.robot import Robot
from lab.scenes import scene_bodies
from lab.scenes.terrain import ScriptedJoints
from lab.world.plant_model import build_spec, mute_shank_meshes, shorten_shanks
from lab.world.plant_sensing import PlantSensing

try:  # the per-tick exchange with MuJoCo in C (cpp/plant); without it the Python path runs
    from lab import _plant
except ImportError:
    _plant = None
if _plant is not None and _plant.mujoco_version != mujoco.mj_versionString():
    _plant = None  # built against another MuJoCo than the one imported: its structs may differ

PAYLOAD_CUBE_SIDE = 0.1  # m: a payload is a solid cube of this side (its own inertia)
# MuJoCo's checks of a bad state: a position, velocity or acceleration that is NaN, inf or beyond
# 1e10 (mjMAXVAL). With the automatic reset off they count, and the state stays as it is.
BAD_STATE_WARNINGS = {
    int(mujoco.mjtWarning.mjWARN_BADQPOS): "position",
    int(mujoco.mjtWarning.mjWARN_BADQVEL): "velocity",
    int(mujoco.mjtWarning.mjWARN_BADQACC): "acceleration",
}
# The sum of squares of qpos and qvel below mjMAXVAL² holds each coordinate below it.
MAX_STATE_SQUARED = mujoco.mjMAXVAL**2


class SimulationDiverged(ArithmeticError):
    """MuJoCo's state is no longer a valid one; the plant must be `reset` before it steps again.

    `cause` says what MuJoCo (or the finiteness check) found and at which degree of freedom;
    `time` is the sim time (s) the bad state was found at, never before the last valid state.
    """

    def __init__(self, cause: str, time: float) -> None:
        super().__init__(cause)
        self.cause = cause
        self.time = time


class MujocoPlant(PlantSensing):
    """One robot in one MuJoCo scene; every argument and result in pinocchio conventions."""

    def __init__(
        self,
        robot: Robot,
        scene: str = "flat",
        timestep: float = 1e-3,
        terrain_seed: int | None = None,
        native: bool = True,
        mj_model: mujoco.MjModel | None = None,
    ) -> None:
        """`native`: run the per-tick calls (check, state, set_torques, step, touch sensing)
        through `lab._plant` when it is built (`self.native` says whether they do). `mj_model`:
        what `build_spec` of these arguments compiles, compiled elsewhere (a worker process:
        lab/world/compiled.py); the plant changes it, so it must be its own."""
        self.robot = robot
        if mj_model is None:
            mj_model = build_spec(robot, scene, timestep, terrain_seed).compile()
        self.mj_model = mj_model
        self.mj_data = mujoco.MjData(self.mj_model)
        m = self.mj_model
        self.moving_terrain = ScriptedJoints(m, scene_bodies(scene))
        self.nq, self.nv = robot.model.nq, robot.model.nv
        joints = [m.joint(name) for name in robot.joint_names]
        if any(j.type[0] != mujoco.mjtJoint.mjJNT_HINGE for j in joints):
            raise ValueError(f"robot {robot.description.name!r}: only hinge joints are supported")
        self._qpos_index = np.array([j.qposadr[0] for j in joints])
        self._dof_index = np.array([j.dofadr[0] for j in joints])
        self._q_order = np.concatenate(([0, 1, 2, 4, 5, 6, 3], self._qpos_index))
        self._v_order = np.concatenate((np.arange(6), self._dof_index))
        self.base_body_id = m.joint("root_joint").bodyid[0]
        self.contact_site_ids = np.array([m.site(c.name).id for c in robot.contacts])
        self.foot_geom_ids = np.array([m.geom(c.name).id for c in robot.contacts])
        foot_of_geom = np.full(m.ngeom, -1)
        foot_of_geom[self.foot_geom_ids] = np.arange(len(robot.contacts))
        shorten_shanks(m, self.foot_geom_ids)
        mute_shank_meshes(m, self.foot_geom_ids)
        # Per geom, as lists for the per-contact loops: is it terrain (not on the robot's tree:
        # the world's geoms and a scene's moving bodies), which foot is it (or −1).
        robot_root = m.body_rootid[self.base_body_id]
        self._terrain_list = (m.body_rootid[m.geom_bodyid] != robot_root).tolist()
        self._foot_of_geom_list = foot_of_geom.tolist()
        self._body_of_link = self._pushable_bodies()
        self.body_names = tuple(sorted(self._body_of_link))
        self._rotation = np.zeros(9)
        self._forces = np.zeros((len(robot.contacts), 3))
        self._steps = 0  # MuJoCo steps and resets so far: the key of the per-step caches
        self._forces_step = -1
        self._contacts: list[tuple[int, int, int, float]] = []
        self._contacts_step = -1
        self._point_pushes: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        # Live views into mj_data (never reallocated): `check` runs twice a tick, ~1 µs this way.
        self._warning_counts = self.mj_data.warning.number
        self._qpos, self._qvel = self.mj_data.qpos, self.mj_data.qvel
        self._ctrl = self.mj_data.ctrl  # `state` and `set_torques` run every tick
        self._base_in_world = self._rotation.reshape(3, 3)  # a view: mju_quat2Mat fills it
        self._coordinate_names = self._name_coordinates()
        self._valid_time = 0.0  # sim time of the last state `check` passed
        self._foot_of_geom = foot_of_geom
        self._viscous = np.zeros(len(joints))  # joint viscous friction (N m s/rad)
        self._damping = np.zeros(len(joints))  # damping on top of it (a fallen robot's)
        self._bare_inertia: dict[int, pin.Inertia] = {}  # bodies' inertias before a payload
        self.payloads: dict[str, float] = {}  # kg by link, what `set_payload` fixed
        self._scratch: mujoco.MjData | None = None  # `warm`'s, made at its first call
        self._native = None
        if native and _plant is not None:
            self._native = _plant.PlantStep(*self.native_structs())
        self.reset(robot.q_standing)

    def native_structs(self) -> tuple:
        """What a native step is built on (lab._plant's PlantStep, lab._kernel's ServerTick):
        the MjModel and MjData, the qpos and qvel indices of pinocchio's q and v, per geom whether
        it is terrain and which foot it is (or -1), and the foot count."""
        return (
            self.mj_model,
            self.mj_data,
            self._q_order.astype(np.int64),
            self._v_order.astype(np.int64),
            np.array(self._terrain_list, dtype=np.int64),
            self._foot_of_geom.astype(np.int64),
            len(self.robot.contacts),
        )

    @property
    def native_step_note(self) -> str:
        """Why the next step cannot run inside the server's native tick ('' when it can): what
        `step` does in Python around mj_step (a scene's moving terrain, a push at a point)."""
        if not self.native:
            return "the plant runs its Python path (lab._plant is not built)"
        if self.moving_terrain.bodies:
            return "the scene's terrain moves (scripted in Python each step)"
        if self._point_pushes:
            return "a push at a point (its lever arm is set in Python each step)"
        return ""

    def warm(self) -> None:
        """MuJoCo's forward dynamics on a scratch copy of the state: brings the code and the
        model the next step runs into the caches, and changes nothing of the plant (the
        server's loop calls it before a deadline, after its sleep: Session.warm)."""
        if self._scratch is None:
            self._scratch = mujoco.MjData(self.mj_model)
        scratch, data = self._scratch, self.mj_data
        scratch.time = data.time
        scratch.qpos[:], scratch.qvel[:], scratch.ctrl[:] = data.qpos, data.qvel, data.ctrl
        scratch.qacc_warmstart[:] = data.qacc_warmstart
        mujoco.mj_forward(self.mj_model, scratch)

    def stepped_elsewhere(self, valid_time: float, stepped: bool) -> None:
        """The server's native tick checked the state at `valid_time` (s) and, if `stepped`,
        stepped: the per-step caches are stale, as after `step`."""
        self._valid_time = valid_time
        if stepped:
            self._steps += 1

    @property
    def native(self) -> bool:
        """Whether the per-tick calls run through `lab._plant` (C) rather than Python."""
        return self._native is not None

    def _pushable_bodies(self) -> dict[str, int]:
        """URDF link name -> MuJoCo body that carries it (links on fixed joints are fused)."""
        model = self.robot.model
        bodies = {}
        for frame in model.frames:
            if frame.type == pin.FrameType.BODY:
                joint = model.names[frame.parentJoint]
                bodies[frame.name] = self.mj_model.joint(joint).bodyid[0]
        return bodies

    def _name_coordinates(self) -> dict[int, list[str]]:
        """Per bad-state warning, the names of the coordinates its `lastinfo` indexes: qpos
        entries for a bad position, degrees of freedom for a bad velocity or acceleration."""
        m = self.mj_model
        qpos = ["base x", "base y", "base z", "base qw", "base qx", "base qy", "base qz"]
        dofs = ["base vx", "base vy", "base vz", "base wx", "base wy", "base wz"]
        qpos += [m.joint(m.dof_jntid[dof]).name for dof in range(6, m.nv)]  # hinges: 1 each
        dofs += qpos[7:]
        warning = mujoco.mjtWarning
        return {
            int(warning.mjWARN_BADQPOS): qpos,
            int(warning.mjWARN_BADQVEL): dofs,
            int(warning.mjWARN_BADQACC): dofs,
        }

    @property
    def time(self) -> float:
        return float(self.mj_data.time)

    def reset(self, q: np.ndarray, v: np.ndarray | None = None, time: float = 0.0) -> None:
        """Put the robot at (q, v) (v = 0 if omitted) at sim time `time` (s), no torque, no push."""
        q = np.asarray(q, dtype=float)
        v = np.zeros(self.nv) if v is None else np.asarray(v, dtype=float)
        if q.shape != (self.nq,) or v.shape != (self.nv,):
            raise ValueError(f"reset needs q of shape ({self.nq},) and v of shape ({self.nv},)")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
            raise ValueError("reset: q and v must be finite")
        if not (math.isfinite(time) and time >= 0.0):
            raise ValueError(f"reset: time must be finite and >= 0 s, not {time}")
        if abs(np.linalg.norm(q[3:7]) - 1.0) > 1e-6:
            raise ValueError("reset: the base quaternion q[3:7] must have unit norm")
        d = self.mj_data
        mujoco.mj_resetData(self.mj_model, d)
        d.qpos[:3] = q[:3]
        d.qpos[3] = q[6]
        d.qpos[4:7] = q[3:6]
        d.qpos[self._qpos_index] = q[7:]
        mujoco.mju_quat2Mat(self._rotation, d.qpos[3:7])
        d.qvel[:3] = self._rotation.reshape(3, 3) @ v[:3]
        d.qvel[3:6] = v[3:6]
        d.qvel[self._dof_index] = v[6:]
        d.time = time
        self.moving_terrain.reset(self.mj_model, d, time)
        self._point_pushes.clear()
        mujoco.mj_forward(self.mj_model, d)
        self._steps += 1  # a new state: measured forces are stale
        self._valid_time = time

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """(q, v) in pinocchio conventions (new arrays)."""
        if self._native is not None:
            return self._native.state()
        qpos, qvel = self._qpos, self._qvel
        q = qpos[self._q_order]  # quaternion (w, x, y, z) → (x, y, z, w), joints by name
        v = qvel[self._v_order]
        mujoco.mju_quat2Mat(self._rotation, qpos[3:7])
        v[:3] = self._base_in_world.T @ v[:3]  # linear velocity: world → base frame
        return q, v

    def velocity_map(self, q: np.ndarray) -> np.ndarray:
        """T with MuJoCo qvel = T v (pinocchio v) at configuration q; M_pin = Tᵀ M_mj T."""
        x, y, z, w = q[3:7]
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, np.array([w, x, y, z]))
        t = np.zeros((self.nv, self.nv))
        t[:3, :3] = rotation.reshape(3, 3)
        t[3:6, 3:6] = np.eye(3)
        t[self._dof_index, np.arange(6, self.nv)] = 1.0
        return t

    def set_torques(self, tau: np.ndarray) -> None:
        """Joint torques (N m) in pinocchio joint order; MuJoCo clips them to the torque limits."""
        tau = np.asarray(tau, dtype=float)
        if self._native is not None and tau.ndim == 1:
            self._native.set_torques(tau)  # ValueError unless na finite torques
            return
        ctrl = self._ctrl
        if tau.shape != ctrl.shape or not np.isfinite(tau).all():
            raise ValueError(f"set_torques needs {ctrl.size} finite torques (N m)")
        ctrl[:] = tau  # actuators were added in pinocchio joint order

    def set_joint_damping(self, damping: float | np.ndarray) -> None:
        """Viscous damping (N m s/rad) of the actuated joints on top of their viscous friction
        (`set_drive_limits`), one value or one per joint in pinocchio order; 0 (the default,
        and what the controller's model assumes) removes it."""
        damping = np.broadcast_to(np.asarray(damping, dtype=float), self._dof_index.shape)
        if not (np.all(np.isfinite(damping)) and np.all(damping >= 0.0)):
            raise ValueError("set_joint_damping: damping must be finite and >= 0 (N m s/rad)")
        self._damping = damping.copy()
        self.mj_model.dof_damping[self._dof_index] = self._viscous + damping

    def set_drive_limits(self, saturation: float, coulomb: float, viscous: float) -> None:
        """The drives' torque limit, `saturation` × the robot's (MuJoCo's ctrlrange clips the
        command), and joint friction in MuJoCo: Coulomb `coulomb` × τ_max (N m,
        dof_frictionloss, a constraint MuJoCo solves) and viscous `viscous` × τ_max (N m s/rad,
        dof_damping, integrated implicitly). Fractions of each joint's torque limit
        (lab/realism/knobs.py checks their ranges); 1, 0, 0 is the ideal drive."""
        values = np.array([saturation, coulomb, viscous], dtype=float)
        if not (np.all(np.isfinite(values)) and 0.0 < saturation <= 1.0 and coulomb >= 0.0):
            raise ValueError("set_drive_limits: saturation in (0, 1], frictions finite and >= 0")
        if viscous < 0.0:
            raise ValueError("set_drive_limits: viscous friction must be >= 0")
        limits = self.robot.torque_limits
        m = self.mj_model
        m.actuator_ctrlrange[:] = np.column_stack((-saturation * limits, saturation * limits))
        m.dof_frictionloss[self._dof_index] = coulomb * limits
        self._viscous = viscous * limits
        m.dof_damping[self._dof_index] = self._viscous + self._damping

    def set_payload(self, body: str, mass: float, offset: np.ndarray) -> None:
        """Fix a payload of `mass` kg (a 10 cm solid cube) at `offset` (m, in the frame of URDF
        link `body`) to the MuJoCo body that carries the link, replacing any payload it had
        (0 kg removes it). Only the simulator's inertia changes: the controller is not told.
        Raises KeyError naming the known bodies, ValueError for a bad mass or offset."""
        if body not in self._body_of_link:
            raise KeyError(f"unknown body {body!r}; known bodies: {', '.join(self.body_names)}")
        offset = np.asarray(offset, dtype=float)
        if offset.shape != (3,) or not np.all(np.isfinite(offset)):
            raise ValueError("payload: offset must be 3 finite numbers (m)")
        if not (math.isfinite(mass) and mass >= 0.0):
            raise ValueError(f"payload: mass must be finite and >= 0 kg, not {mass}")
        m, b = self.mj_model, self._body_of_link[body]
        if b not in self._bare_inertia:
            w, x, y, z = m.body_iquat[b]
            rotation = pin.Quaternion(w, x, y, z).normalized().matrix()
            self._bare_inertia[b] = pin.Inertia(
                float(m.body_mass[b]),
                m.body_ipos[b].copy(),
                rotation @ np.diag(m.body_inertia[b]) @ rotation.T,
            )
        # The link's frame in its joint's, which is the MuJoCo body's frame (fixed links fused)
        in_body = self.robot.model.frames[
            self.robot.model.getFrameId(body, pin.FrameType.BODY)
        ].placement
        cube = mass * PAYLOAD_CUBE_SIDE**2 / 6.0 * np.eye(3)
        total = self._bare_inertia[b] + pin.Inertia(mass, in_body.act(offset), cube)
        moments, axes = np.linalg.eigh(total.inertia)
        if np.linalg.det(axes) < 0.0:
            axes[:, 0] *= -1.0
        quat = pin.Quaternion(axes)
        m.body_mass[b] = total.mass
        m.body_ipos[b] = total.lever
        m.body_inertia[b] = moments
        m.body_iquat[b] = [quat.w, quat.x, quat.y, quat.z]
        mujoco.mj_setConst(m, mujoco.MjData(m))  # subtree masses; a scratch MjData
        self.payloads[body] = mass

    def step(self) -> None:
        """One timestep. A push at a point gets its lever arm from this step's kinematics.
        Raises `SimulationDiverged` if the state after it is not valid (see `check`)."""
        m, d = self.mj_model, self.mj_data
        self._steps += 1
        if self.moving_terrain.bodies:  # MjData.time alone costs ~0.4 µs from Python
            self.moving_terrain.apply(m, d, d.time)
        if self._native is not None and not self._point_pushes:
            time = self._native.step()  # the new sim time, -1 when the new state is not valid
            if time < 0.0:
                self.check()  # names why
            else:
                self._valid_time = time
            return
        if not self._point_pushes:
            mujoco.mj_step(m, d)
        else:
            mujoco.mj_step1(m, d)
            for body, (force, local) in self._point_pushes.items():
                point = d.xpos[body] + d.xmat[body].reshape(3, 3) @ local
                d.xfrc_applied[body, 3:] = np.cross(point - d.xipos[body], force)
            mujoco.mj_step2(m, d)
        self.check()

    def check(self) -> None:
        """Raise `SimulationDiverged` unless the state is valid: MuJoCo flagged no bad position,
        velocity or acceleration since the last `reset`, and qpos and qvel are finite and within
        MuJoCo's own bound (a state its next step would flag: the controller never sees it)."""
        if self._native is not None:
            time = self._native.check()  # the sim time, -1 when the state is not valid
            if time >= 0.0:
                self._valid_time = time
                return
        d, counts, qpos, qvel = self.mj_data, self._warning_counts, self._qpos, self._qvel
        flagged = any(counts[kind] for kind in BAD_STATE_WARNINGS)
        # NaN and inf propagate into the sum and fail the comparison
        if not flagged and qpos.dot(qpos) + qvel.dot(qvel) < MAX_STATE_SQUARED:
            self._valid_time = d.time
            return
        cause = f"non-finite position or velocity, or one beyond {mujoco.mjMAXVAL:g}"
        for kind, quantity in BAD_STATE_WARNINGS.items():
            if counts[kind]:
                where = self._coordinate_names[kind][d.warning[kind].lastinfo]
                cause = f"MuJoCo: NaN, inf or huge {quantity} ({where})"
                break
        time = d.time
        raise SimulationDiverged(cause, time if time >= self._valid_time else self._valid_time)

    def push(
        self, body: str, force_world: np.ndarray, point_world: np.ndarray | None = None
    ) -> None:
        """Apply `force_world` (N, world frame) to URDF link `body` until `clear_push`.

        Without `point_world` the force acts at the centre of mass of the moving body that carries
        the link; with it, at that point (fixed to the body from now on), i.e. force plus the torque
        of its lever arm about that centre of mass.
        """
        if body not in self._body_of_link:
            raise KeyError(f"unknown body {body!r}; known bodies: {', '.join(self.body_names)}")
        force = np.asarray(force_world, dtype=float)
        if force.shape != (3,) or not np.all(np.isfinite(force)):
            raise ValueError("push: force_world must be 3 finite numbers (N)")
        if point_world is not None:
            point = np.asarray(point_world, dtype=float)
            if point.shape != (3,) or not np.all(np.isfinite(point)):
                raise ValueError("push: point_world must be 3 finite numbers (m)")
        b = self._body_of_link[body]
        d = self.mj_data
        d.xfrc_applied[b, :3] = force
        d.xfrc_applied[b, 3:] = 0.0
        self._point_pushes.pop(b, None)
        if point_world is not None:
            local = d.xmat[b].reshape(3, 3).T @ (point - d.xpos[b])
            self._point_pushes[b] = (force.copy(), local)
            d.xfrc_applied[b, 3:] = np.cross(point - d.xipos[b], force)

    def clear_push(self) -> None:
        self.mj_data.xfrc_applied[:] = 0.0
        self._point_pushes.clear()
