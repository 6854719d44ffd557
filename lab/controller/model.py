"""RobotModel: the one place that talks to pinocchio and knows its frame conventions.

One `update(q, v)` per tick runs a single pinocchio pass (`computeAllTerms`) and exposes what the
tasks and constraints need: the joint-space inertia M, the bias forces h, the contact Jacobians
with their drift J̇v, the CoM with its Jacobian and drift, and the centroidal momentum map.

Conventions (pinocchio's, kept everywhere in the controller):
- q = [base position in world, base quaternion (x, y, z, w), joint positions].
- v = [base linear velocity, base angular velocity (both in the base frame), joint velocities].
- x = [q̈, F], the decision variable of every hierarchy solver. F stacks one block per contact:
  a point foot's force in world axes at the foot centre (3), a flat foot's wrench in the sole
  frame at the sole centre (6).
"""

import itertools
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from lab.protocol import ContactSpec

BASE_DOF = 6


class RobotModel:
    """Kinematics and dynamics of one floating-base robot at the current state."""

    def __init__(self, model: pin.Model, contacts: Sequence[ContactSpec]) -> None:
        self.model = model
        self.data = model.createData()
        self.contacts = tuple(contacts)
        self.nq = model.nq
        self.nv = model.nv
        self.na = model.nv - BASE_DOF
        self.mass = float(sum(inertia.mass for inertia in model.inertias))
        self.gravity = np.array(model.gravity.linear)
        self.joint_names = tuple(model.names[2:])  # drop 'universe' and the free-flyer
        self.frame_ids = tuple(model.getFrameId(c.frame) for c in self.contacts)
        for contact, fid in zip(self.contacts, self.frame_ids, strict=True):
            if fid >= model.nframes:
                raise KeyError(f"contact frame {contact.frame!r} is not in the model")

        starts = np.cumsum([0] + [c.force_dim for c in self.contacts])
        self.force_slices = tuple(slice(int(a), int(b)) for a, b in itertools.pairwise(starts))
        self.force_dims = np.array([c.force_dim for c in self.contacts])
        self.nf = int(starts[-1])
        self.nx = self.nv + self.nf

        # Filled by update(); preallocated so that the tick does not allocate them again.
        self.q: np.ndarray = pin.neutral(model)
        self.v = np.zeros(self.nv)
        self.M = np.zeros((self.nv, self.nv))
        self.h = np.zeros(self.nv)
        self.Jc = np.zeros((self.nf, self.nv))
        self.Jc_dot_v = np.zeros(self.nf)
        self.com = np.zeros(3)
        self.com_velocity = np.zeros(3)
        self.Jcom = np.zeros((3, self.nv))
        self.com_drift = np.zeros(3)
        self.base_rotation = np.eye(3)
        self.contact_positions = np.zeros((len(self.contacts), 3))
        self.contact_rotations = np.zeros((len(self.contacts), 3, 3))
        self.centroidal_map = np.zeros((6, self.nv))  # A_G: h = A_G v (Herzog eq. 19)
        self._centroidal_drift: np.ndarray | None = None
        # Which pass filled the arrays last: "python" (update) or "native" (a kernel's update
        # through `arrays()`, which leaves `data` behind: frame_position redoes the placements).
        self.updated_by = "python"
        self._placements_current = False

    def update(self, q: np.ndarray, v: np.ndarray) -> None:
        """Recompute everything at state (q, v) in one pinocchio pass."""
        model, data = self.model, self.data
        self.q[:] = q
        self.v[:] = v
        self.updated_by, self._placements_current = "python", True
        # computeAllTerms: M, nle, joint Jacobians, CoM (+Jacobian), centroidal map, and the
        # drift accelerations (q̈ = 0) of every joint, which give J̇v below.
        pin.computeAllTerms(model, data, q, v)
        # computeAllTerms leaves data.acom at zero: the CoM's drift J̇_com v, from the joints'
        # drift accelerations it computed
        pin.centerOfMass(model, data, pin.ACCELERATION, False)
        pin.updateFramePlacements(model, data)
        self.M[:] = data.M
        self.h[:] = data.nle
        self.com[:] = data.com[0]
        self.com_velocity[:] = data.vcom[0]
        self.com_drift[:] = data.acom[0]
        self.Jcom[:] = data.Jcom
        self.base_rotation[:] = pin.Quaternion(q[3:7]).toRotationMatrix()
        self.centroidal_map[:] = data.Ag
        self._centroidal_drift = None
        for i, (contact, fid, rows) in enumerate(
            zip(self.contacts, self.frame_ids, self.force_slices, strict=True)
        ):
            placement = data.oMf[fid]
            self.contact_positions[i] = placement.translation
            self.contact_rotations[i] = placement.rotation
            if contact.kind == "point":
                frame = pin.LOCAL_WORLD_ALIGNED
                self.Jc[rows] = pin.getFrameJacobian(model, data, fid, frame)[:3]
                acc = pin.getFrameClassicalAcceleration(model, data, fid, frame)
                self.Jc_dot_v[rows] = acc.linear
            else:
                frame = pin.LOCAL
                self.Jc[rows] = pin.getFrameJacobian(model, data, fid, frame)
                acc = pin.getFrameClassicalAcceleration(model, data, fid, frame)
                self.Jc_dot_v[rows] = acc.vector

    def arrays(self) -> dict[str, np.ndarray]:
        """The preallocated arrays update() fills, by name: a native kernel's model update fills
        the same ones in place (then call `filled_elsewhere`)."""
        names: tuple[str, ...] = ("q", "v", "M", "h", "Jc", "Jc_dot_v", "com", "com_velocity")
        names += ("com_drift", "Jcom")
        names += ("centroidal_map", "base_rotation", "contact_positions", "contact_rotations")
        return {name: getattr(self, name) for name in names}

    def filled_elsewhere(self) -> None:
        """The arrays now hold a state a native kernel's update wrote (see `arrays`)."""
        self.updated_by, self._placements_current = "native", False
        self._centroidal_drift = None

    def frame_position(self, frame: str) -> np.ndarray:
        """Position of a model frame (a body or a foot) in world axes at the current state."""
        if not self._placements_current:
            pin.framesForwardKinematics(self.model, self.data, self.q)
            self._placements_current = True
        return self.data.oMf[self.model.getFrameId(frame)].translation.copy()

    @property
    def base_position(self) -> np.ndarray:
        """Base position in world (m), a view of q."""
        return self.q[:3]

    @property
    def base_quaternion(self) -> np.ndarray:
        """Base orientation as a quaternion (x, y, z, w), a view of q."""
        return self.q[3:7]

    @property
    def joint_positions(self) -> np.ndarray:
        """Actuated joint positions (rad, m for prismatic joints), pinocchio order; a view of q."""
        return self.q[7:]

    @property
    def base_linear_velocity(self) -> np.ndarray:
        """Base linear velocity in the base frame (m/s), a view of v."""
        return self.v[:3]

    @property
    def base_angular_velocity(self) -> np.ndarray:
        """Base angular velocity in the base frame (rad/s), a view of v."""
        return self.v[3:6]

    @property
    def joint_velocities(self) -> np.ndarray:
        """Actuated joint velocities (rad/s), pinocchio order; a view of v."""
        return self.v[BASE_DOF:]

    @property
    def base_angular_velocity_world(self) -> np.ndarray:
        """Base angular velocity in world axes (rad/s)."""
        return self.base_rotation @ self.v[3:6]

    @property
    def base_linear_velocity_world(self) -> np.ndarray:
        """Base linear velocity in world axes (m/s)."""
        return self.base_rotation @ self.v[:3]

    def scratch(self) -> "RobotModel":
        """A second model of the same robot, with its own pinocchio data: for computing at
        another state (a standing posture, say) without moving this one."""
        return RobotModel(self.model, self.contacts)

    def centroidal_momentum(self) -> np.ndarray:
        """[linear; angular] momentum about the CoM, world axes: h_G = A_G v (Herzog eq. 19)."""
        return self.centroidal_map @ self.v

    def centroidal_drift(self) -> np.ndarray:
        """Ȧ_G v, the rate of change of the centroidal momentum at q̈ = 0 (Herzog eq. 20), world
        axes, [linear; angular] about the CoM. One more pinocchio pass, on demand, once per
        update (only the momentum task needs it)."""
        if self._centroidal_drift is None:
            dAg = pin.computeCentroidalMapTimeVariation(self.model, self.data, self.q, self.v)
            self._centroidal_drift = dAg @ self.v
        return self._centroidal_drift

    def contact_forces_world(self, forces: np.ndarray) -> np.ndarray:
        """The force of each contact (n_contacts, 3) in world axes, from the F part of x.

        A point foot's force already is; a flat foot's is rotated out of its sole frame.
        """
        out = np.empty((len(self.contacts), 3))
        for i, (contact, rows) in enumerate(zip(self.contacts, self.force_slices, strict=True)):
            f = forces[rows][:3]
            out[i] = f if contact.kind == "point" else self.contact_rotations[i] @ f
        return out

    def joint_torques(self, x: np.ndarray) -> np.ndarray:
        """τ = M_a q̈ + h_a − J_aᵀ F, the actuated rows of the dynamics (Herzog eq. 14)."""
        qdd, forces = x[: self.nv], x[self.nv :]
        a = slice(BASE_DOF, None)
        tau: np.ndarray = self.M[a] @ qdd + self.h[a] - self.Jc[:, a].T @ forces
        return tau
