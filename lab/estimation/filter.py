"""The EKF itself: predict with the IMU, make a foot's state at its touchdown, correct with the
leg kinematics of the feet in contact (Bloesch et al. 2013; the error-state form of Solà 2017
§6: the error's mean is injected into the nominal state after each correction and reset to 0).

The caller says which feet are in contact: the controller's contact state (the behaviour's
schedule and touchdowns), not the simulator's contact flags. The filter starts at a known pose
(the lab's world frame is the start's); the base's absolute position and yaw are then
unobservable (Bloesch et al.'s observability analysis), and drift with the IMU's and the
kinematics' errors.

The height's drift, and why the kinematics count less along the vertical after a touchdown: a
foot's contact is not rigid. ANYmal trotting in MuJoCo, a touching-down foot's centre sinks
about 4.5 mm into the ground within 30 ms and springs back over the next 100–200 ms, while the
feet it relieves rise by about 0.5 mm as they unload (docs/realism.md "The state estimator").
The filter's feet stand still but for a random walk, and a new foot is fresh: the fast sink
went into the new foot's state (the IMU holds the base over 30 ms), the slower rise and the
unloading into the base's. Each step lost 1–2 mm of height: the estimate sank 0.4–0.9 cm/s.
Anchoring the new foot rigidly instead made the drift depend on the tick at which the contact
flag turns on (the foot comes down at ~0.7 mm a tick): +1.4 to +3.5 mm/s. So for
`tuning.settle` s after any touchdown every foot's kinematics count along the world vertical
with `tuning.settling_kinematics` (the contact's give), across it as before: the IMU carries
the height over the exchange of feet, the kinematics the rest.
"""

import math

import numpy as np
import pinocchio as pin

from lab.estimation.measurement import LegKinematics, foot_innovation, touchdown_map
from lab.estimation.process import process_noise, propagate, roll_feet, transition
from lab.estimation.state import ErrorLayout, NominalState
from lab.estimation.tuning import EkfTuning


class LeggedEkf:
    """The base's pose, twist and IMU biases of a robot whose feet `kinematics` gives (spheres
    of `radii` m about those points, 0 for a point or a sole), ticked every `dt` s under
    `gravity` (m/s², world)."""

    def __init__(
        self,
        kinematics: LegKinematics,
        radii: np.ndarray,
        gravity: np.ndarray,
        dt: float,
        tuning: EkfTuning | None = None,
    ) -> None:
        self.kinematics, self.gravity, self.dt = kinematics, gravity, dt
        self.radii = np.asarray(radii, dtype=float)
        self.tuning = tuning or EkfTuning()
        self.layout = ErrorLayout(len(kinematics.frame_ids))
        self.reset(pin.neutral(kinematics.model), np.zeros(kinematics.model.nv))

    def reset(self, q: np.ndarray, v: np.ndarray) -> None:
        """Start at the known state (q, v) (pinocchio's configuration and velocity), no bias
        yet, no foot in contact yet (the next `step` puts those in contact down)."""
        tuning, layout = self.tuning, self.layout
        rotation = pin.Quaternion(q[6], q[3], q[4], q[5]).normalized().matrix()
        position = q[:3].copy()
        self.x = NominalState(
            position=position,
            velocity=rotation @ v[:3],
            rotation=rotation,
            feet=position + self.kinematics.feet(q[7:]) @ rotation.T,
            accel_bias=np.zeros(3),
            gyro_bias=np.zeros(3),
        )
        sigma = np.zeros(layout.size)
        sigma[layout.p] = tuning.initial_position
        sigma[layout.v] = tuning.initial_velocity
        sigma[layout.theta] = tuning.initial_orientation
        sigma[layout.accel_bias] = tuning.initial_accel_bias
        sigma[layout.gyro_bias] = tuning.initial_gyro_bias
        for foot in layout.feet:
            sigma[foot] = tuning.kinematics
        self.P = np.diag(sigma**2)
        self.contacts = np.zeros(layout.n, dtype=bool)
        self.since_touchdown = math.inf  # s since the last touchdown of any foot

    def step(
        self,
        accel: np.ndarray,
        gyro: np.ndarray,
        joints: np.ndarray,
        joint_velocities: np.ndarray,
        contacts: np.ndarray,
    ) -> None:
        """One tick: the IMU's readings `accel` (m/s²) and `gyro` (rad/s, base frame) over
        it, the joint angles `joints` (rad) and rates `joint_velocities` (rad/s) at its end,
        the feet in contact `contacts`."""
        x, layout = self.x, self.layout
        if np.any(self.radii > 0.0):
            spins = self.kinematics.spins(joints, joint_velocities)
            roll_feet(x, spins, gyro, self.radii, self.contacts, self.dt)
        F = transition(x, accel, gyro, self.dt, layout)
        propagate(x, accel, gyro, self.gravity, self.dt)
        self.P = F @ self.P @ F.T
        self.P[np.diag_indices(layout.size)] += process_noise(
            self.tuning, self.contacts, self.dt, layout
        )
        feet = self.kinematics.feet(joints)
        for i in np.flatnonzero(contacts & ~self.contacts):
            self._touchdown(int(i), feet[i])
            self.since_touchdown = 0.0
        self.contacts = np.array(contacts, dtype=bool)
        self._correct(feet)
        self.since_touchdown += self.dt

    def _touchdown(self, i: int, measured: np.ndarray) -> None:
        """Foot `i` touches down where the kinematics `measured` (base frame) put it: its part
        of x and its rows and columns of P anew (measurement.py)."""
        x, foot = self.x, self.layout.feet[i]
        T = np.eye(self.layout.size)
        T[foot] = touchdown_map(x, measured, self.layout)
        self.P = T @ self.P @ T.T
        self.P[foot, foot] += self.tuning.kinematics**2 * np.eye(3)
        x.feet[i] = x.position + x.rotation @ measured

    def _correct(self, feet: np.ndarray) -> None:
        """The EKF correction with the kinematics `feet` (n, 3) of the feet in contact, in
        Joseph's form; the error's mean injected into x."""
        standing = np.flatnonzero(self.contacts)
        if standing.size == 0:
            return
        rows = [foot_innovation(self.x, int(i), feet[i], self.layout) for i in standing]
        residual = np.concatenate([r for r, _ in rows])
        H = np.vstack([h for _, h in rows])
        noise = kinematics_noise(self.tuning, self.x.rotation, self.since_touchdown)
        N = np.kron(np.eye(standing.size), noise)  # the feet's readings are independent
        PHt = self.P @ H.T
        S = H @ PHt + N
        K = np.linalg.solve(S, PHt.T).T  # P Hᵀ S⁻¹ (S symmetric)
        IKH = np.eye(self.layout.size) - K @ H
        self.P = IKH @ self.P @ IKH.T + K @ N @ K.T
        self.P = 0.5 * (self.P + self.P.T)
        self._inject(K @ residual)

    def _inject(self, dx: np.ndarray) -> None:
        """x ← x ⊕ δx (R ← R Exp(δθ)); δx's mean is then 0 (Solà §6.2–6.3; the covariance's reset
        Jacobian I − [δθ/2]× is taken as I, δθ being small)."""
        x, layout = self.x, self.layout
        x.position += dx[layout.p]
        x.velocity += dx[layout.v]
        x.rotation = x.rotation @ pin.exp3(dx[layout.theta])
        for i, foot in enumerate(layout.feet):
            x.feet[i] += dx[foot]
        x.accel_bias += dx[layout.accel_bias]
        x.gyro_bias += dx[layout.gyro_bias]

    # ------------------------------------------------------------------ what the controller reads
    def configuration(self, joints: np.ndarray) -> np.ndarray:
        """q = [p̂, R̂ as a quaternion (x, y, z, w), `joints`] (pinocchio's configuration)."""
        quaternion = pin.Quaternion(self.x.rotation).normalized().coeffs()
        return np.concatenate((self.x.position, quaternion, joints))

    def velocity(self, gyro: np.ndarray, joint_velocities: np.ndarray) -> np.ndarray:
        """v = [R̂ᵀ v̂, ω̃ − b̂_g, `joint_velocities`] (pinocchio's: base twist in the base
        frame)."""
        x = self.x
        return np.concatenate((x.rotation.T @ x.velocity, gyro - x.gyro_bias, joint_velocities))


def kinematics_noise(tuning: EkfTuning, rotation: np.ndarray, since_touchdown: float) -> np.ndarray:
    """The covariance (3, 3, base frame) of one foot's kinematics reading `since_touchdown` s
    after the last touchdown, the base's orientation `rotation`: σ_s² I, its world-vertical
    part σ_settle² while the contacts settle (module docstring)."""
    noise = tuning.kinematics**2 * np.eye(3)
    if since_touchdown < tuning.settle:
        up = rotation[2]  # the world's vertical in the base frame: Rᵀ e_z
        noise += (tuning.settling_kinematics**2 - tuning.kinematics**2) * np.outer(up, up)
    return noise
