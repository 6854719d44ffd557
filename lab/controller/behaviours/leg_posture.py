"""Posture references of the legs from their feet (Raiola §3.4, eqs. 30–32).

The postural task (eq. 9) tracks joint positions q_d and velocities q̇_d; Raiola maps Cartesian
foot motion relative to the base into them by closed-loop inverse kinematics, leg by leg,
q̇_d = J_i⁻¹ ṙ_d, q_d found by integration:

- a swinging leg (eq. 30): ṙ_d = ẋ_f,d + P (x_f,d − x_f), the swing trajectory relative to the
  base (Raiola's world frame W is attached to the base origin, §2.4.1);
- a stance leg (eq. 31): ṙ_d = P ΔH_bl, ΔH_bl = [0, 0, −ΔH_z], ΔH_z = h_d − h (eq. 32), h the
  base height over the stance feet (eq. 17): the legs stretch or fold to set the base height.

Eq. 31 moves the stance feet relative to the base only vertically, so the stance legs' posture
holds the base where it stood over them at touchdown, braking the walk (the base is moved only
by the posture in S3). The stance feet here also move relative to the base by what the commanded
twist asks of the base, ṙ_d = −(v_d + ω_d × r) + P ΔH_bl: the same feed-forward eq. 30 has, with
the base's commanded instead of its measured velocity (no base velocity estimate, as in Raiola;
why, measured: docs/locomotion.md).

The controller's point contact is the foot sphere's centre, but a rigid sphere on a pitching
shank rolls: without slipping its centre moves by ω_f × ρ ẑ (ρ its radius, ω_f the foot's
angular velocity, flat ground assumed). A stance reference that keeps the centre still relative
to the ground lets the base gain that rolling distance every step (docs/locomotion.md). So the
stance rate also carries the measured rolling of the foot: the base then moves at v_d relative
to the ground, not to the foot centre.

Each leg's integration starts from its measured joints at lift-off and at touchdown, so a
haptic touchdown early or late (rough ground) starts the stance from where the leg really is.
Joint velocities, foot offsets r = x_f − x_base and the Jacobians are in world axes.

On a tick whose model update the native kernel ran, `update` computes q̇_d with the same
steps in C++ (cpp/behaviours/leg_posture.cpp, when built); this module stays the reference.
"""

import numpy as np
import pinocchio as pin
from scipy.linalg.lapack import dposv as posv

from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.tasks.posture import leg_joints

try:
    from lab._kernel import leg_posture_velocity as native_velocity
except ImportError:  # the native kernel is not built: every tick runs the code below
    native_velocity = None

CLIK_GAIN = 10.0  # 1/s, P of eqs. 30–31 (Raiola Table 2)
DAMPING = 1e-3  # damped least squares near a stretched leg's singularity
MAX_CARRY = 0.01  # m, the largest base lag a touchdown carries over


_DAMPING_3 = DAMPING**2 * np.eye(3)


def _inverse(J: np.ndarray, velocity: np.ndarray) -> np.ndarray:
    """J⁻¹ velocity for a point foot's 3-row Jacobian, damped near singular configurations."""
    return J.T @ np.linalg.solve(J @ J.T + _DAMPING_3, velocity)


class LegPostureReference:
    """Integrated joint references q_d and their velocities q̇_d for every leg."""

    def __init__(self, robot: RobotModel, q_joints: np.ndarray) -> None:
        self.joints = leg_joints(robot)
        # All legs are solved at once: the feet's Jacobian over the actuated joints, J, is
        # block-diagonal up to the order of its columns (a foot moves with its own leg's joints
        # only), as long as no joint moves two feet.
        joints = np.concatenate(self.joints).tolist()
        if len(set(joints)) != len(joints):
            raise ValueError("leg posture references need legs that share no joint")
        self._damping = DAMPING**2 * np.eye(robot.nf)
        self.position = q_joints.copy()
        self.velocity = np.zeros_like(q_joints)
        self.radius = [contact.radius for contact in robot.contacts]
        self._radius = np.array(self.radius)  # the native update's copy
        self._rotations = robot.contact_rotations.copy()  # the feet's orientations last tick

    def restart(self, robot: RobotModel, leg: int, carry_from: list[int]) -> None:
        """Restart leg's integration from its measured joints (at lift-off and touchdown). At
        touchdown the new stance reference carries the mean horizontal lag of the base behind
        the references of the legs `carry_from` (those standing since before this tick), so
        that the base's position error outlives the step and its mean velocity converges."""
        j = self.joints[leg]
        self.position[j] = robot.joint_positions[j]
        others = carry_from
        if not others:
            return
        lag = np.zeros(3)
        for k in others:
            jk = self.joints[k]
            J = robot.Jc[robot.force_slices[k], BASE_DOF + jk]
            lag += J @ (self.position[jk] - robot.joint_positions[jk]) / len(others)
        lag[2] = 0.0
        lag *= min(1.0, MAX_CARRY / max(float(np.linalg.norm(lag)), 1e-12))
        J = robot.Jc[robot.force_slices[leg], BASE_DOF + j]
        self.position[j] += _inverse(J, lag)

    def update(
        self,
        robot: RobotModel,
        dt: float,
        stance: np.ndarray,
        foot_position: np.ndarray,
        foot_velocity: np.ndarray,
        base_velocity: np.ndarray,
        base_angular_velocity: np.ndarray,
        height_error: float,
    ) -> None:
        """Integrate one tick. `stance` flags the legs in stance, `foot_*` are the swing
        references (world; rows of stance legs unused), `base_*` the commanded base twist
        (world), `height_error` ΔH_z of eq. 32."""
        if native_velocity is not None and robot.updated_by == "native":
            native_velocity(
                robot.contact_positions,
                robot.contact_rotations,
                self._rotations,
                robot.Jc,
                self._radius,
                stance,
                foot_position,
                foot_velocity,
                robot.base_position,
                base_velocity,
                base_angular_velocity,
                height_error,
                dt,
                DAMPING,
                self.velocity,
            )
            self.position += dt * self.velocity
            return
        base = robot.base_position
        turn = pin.skew(base_angular_velocity)
        r = robot.contact_positions - base
        # A stance foot moves against the commanded base twist, and by P ΔH_bl (eq. 31) ...
        rate = -(base_velocity + r @ turn.T)
        rate[:, 2] -= CLIK_GAIN * height_error
        if dt > 0.0:  # ... plus the sphere's rolling, ω_f × ρ ẑ = ρ [ω_y, −ω_x, 0]
            turned = robot.contact_rotations @ self._rotations.transpose(0, 2, 1)
            for i, standing in enumerate(stance.tolist()):
                if standing:
                    wx, wy, _ = pin.log3(turned[i]).tolist()  # ω_f dt
                    roll = self.radius[i] / dt
                    rate[i, 0] += roll * wy
                    rate[i, 1] -= roll * wx
        # A swinging foot tracks its swing trajectory relative to the base (eq. 30).
        r_d = foot_position - base
        swing = foot_velocity - base_velocity - r_d @ turn.T + CLIK_GAIN * (r_d - r)
        rate = np.where(stance[:, None], rate, swing)
        self._rotations[:] = robot.contact_rotations
        # q̇ = Jᵀ (J Jᵀ + λ² I)⁻¹ ṙ of every leg in one block-diagonal system, positive definite
        # thanks to λ² I: one Cholesky solve (LAPACK posv). Joints outside the legs get q̇ = 0.
        J = robot.Jc[:, BASE_DOF:]
        _, y, _ = posv(J @ J.T + self._damping, rate.ravel())
        self.velocity[:] = J.T @ y
        self.position += dt * self.velocity
