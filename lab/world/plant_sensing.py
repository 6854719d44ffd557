"""What the plant measures: the feet's contacts with the terrain, and the named reads of the
scene that metrics and telemetry use (never MuJoCo's `mj_data` outside the plant).

`PlantSensing` is the part of `MujocoPlant` (plant.py) that reads the last step: which feet touch
(haptic touchdown), the terrain's force on each foot and its centre of pressure, whether another
body touches the terrain (the fall check), and the moving terrain's poses and joints. Results are
in the world frame; the per-step caches are keyed on the plant's step count.
"""

import functools
from typing import Any

import mujoco
import numpy as np

from lab.scenes.terrain import ScriptedJoints, scripted_joint_name


class PlantSensing:
    """The reads of `MujocoPlant` (module docstring); the plant sets what is declared here."""

    mj_model: mujoco.MjModel
    mj_data: mujoco.MjData
    moving_terrain: ScriptedJoints
    _native: Any  # lab._plant.PlantStep when it is built, else None
    _steps: int  # MuJoCo steps and resets so far: the key of the per-step caches
    _forces: np.ndarray
    _forces_step: int
    _contacts: list[tuple[int, int, int, float]]
    _contacts_step: int
    _terrain_list: list[bool]
    _foot_of_geom_list: list[int]

    def _terrain_contacts(self) -> list[tuple[int, int, int, float]]:
        """(contact, foot or −1, first constraint row or −1, sign) of each contact of the last step
        between the robot and the terrain. The sign is +1 where the robot's geom is geom2: the
        contact force acts from geom1 onto geom2. A plain loop: a step has a handful of
        contacts, fewer than the numpy calls that would replace it cost. Computed once per step:
        the touch sensing, the measured forces and the fall check all read it."""
        if self._contacts_step == self._steps:
            return self._contacts
        d = self.mj_data
        terrain, foot_of = self._terrain_list, self._foot_of_geom_list
        geoms, rows = d.contact.geom[: d.ncon].tolist(), d.contact.efc_address[: d.ncon].tolist()
        found = []
        for i, ((g1, g2), row) in enumerate(zip(geoms, rows, strict=True)):
            if terrain[g1] != terrain[g2]:  # one side is the robot
                robot_geom, sign = (g2, 1.0) if terrain[g1] else (g1, -1.0)
                found.append((i, foot_of[robot_geom], row, sign))
        self._contacts, self._contacts_step = found, self._steps
        return found

    def non_foot_ground_contact(self) -> bool:
        """Does any robot geom other than the feet touch the terrain?"""
        if self._native is not None:
            return self._native.non_foot_ground_contact()
        return any(foot < 0 for _, foot, _, _ in self._terrain_contacts())

    def feet_touching(self, min_normal_force: float) -> np.ndarray:
        """Which feet press on the terrain with a normal force above `min_normal_force` (N).

        The touch sensor of haptic touchdown: cheaper than `foot_forces`, it reads only each
        contact's normal force (the first constraint force of an elliptic-cone contact).
        """
        if self._native is not None and min_normal_force >= 0.0:
            return self._native.foot_normal_forces() > min_normal_force
        efc_force = self.mj_data.efc_force
        touching = np.zeros(len(self._forces), dtype=bool)
        for _, foot, row, _ in self._terrain_contacts():
            if foot >= 0 and row >= 0 and efc_force[row] > min_normal_force:
                touching[foot] = True
        return touching

    def foot_pressure_centres(self) -> np.ndarray:
        """Measured centre of pressure of each foot (n_contacts, 3), m, world frame: its contact
        points weighted by their normal forces; NaN for a foot that does not press."""
        # Python floats, the same sums in the same order: numpy's per-element indexing and
        # in-place adds cost 36 µs a tick for Talos's eight sole contacts (sole_cop metric)
        total = [0.0] * len(self._forces)
        moment = [[0.0, 0.0, 0.0] for _ in self._forces]
        efc_force, points = self.mj_data.efc_force, self.mj_data.contact.pos
        for i, foot, row, _ in self._terrain_contacts():
            if foot >= 0 and row >= 0 and (force := float(efc_force[row])) > 0.0:
                total[foot] += force
                x, y, z = points[i].tolist()
                m = moment[foot]
                m[0] += force * x
                m[1] += force * y
                m[2] += force * z
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.array(moment) / np.array(total)[:, None]

    def foot_forces(self) -> np.ndarray:
        """Measured terrain force on each foot (n_contacts, 3), N, world frame.

        Computed once per step: the session, the metrics and the telemetry all ask for it.
        """
        if self._forces_step == self._steps:
            return self._forces.copy()
        self._forces_step = self._steps
        if self._native is not None:
            self._native.foot_forces(self._forces)
            return self._forces.copy()
        self._forces[:] = 0.0
        efc_force, frames = self.mj_data.efc_force, self.mj_data.contact.frame
        for i, foot, row, sign in self._terrain_contacts():
            if foot >= 0 and row >= 0:
                # Elliptic cones: a contact's first three constraint forces are its normal and two
                # tangential components in the contact frame, whose rows are the frame's axes.
                self._forces[foot] += sign * efc_force[row : row + 3].dot(frames[i].reshape(3, 3))
        return self._forces.copy()

    # ------------------------------------------------------------------ named reads for metrics
    @property
    def timestep(self) -> float:
        """The MuJoCo step, s."""
        return float(self.mj_model.opt.timestep)

    def scene_body_poses(self) -> dict[str, list[float]]:
        """Each moving terrain body's world pose, [x, y, z, qw, qx, qy, qz] (none in a static
        scene)."""
        return self.moving_terrain.poses(self.mj_data)

    @functools.cached_property
    def _scripted_joints(self) -> list[tuple[str, int]]:
        """(name, qpos address) of each scripted joint of the moving terrain, body by body."""
        names = [
            scripted_joint_name(b.name, k)
            for b in self.moving_terrain.bodies
            for k in range(len(b.joints))
        ]
        return [(name, int(self.mj_model.joint(name).qposadr[0])) for name in names]

    def scripted_joint_positions(self) -> dict[str, float]:
        """Each scripted joint of the moving terrain by name (`scripted_joint_name`), body by
        body: m for a slide, rad for a hinge."""
        qpos = self.mj_data.qpos
        return {name: float(qpos[address]) for name, address in self._scripted_joints}

    def terrain_frame(self) -> tuple[np.ndarray, np.ndarray]:
        """Position and rotation (world) of the scene's first moving body; the world's own
        frame in a static scene."""
        if not self.moving_terrain.body_ids:
            return np.zeros(3), np.eye(3)
        body, d = self.moving_terrain.body_ids[0], self.mj_data
        return d.xpos[body].copy(), d.xmat[body].reshape(3, 3).copy()
