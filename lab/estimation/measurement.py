"""The measurement model: the leg kinematics of the feet in contact (Bloesch et al. 2013), and
a foot's entry into the state at its touchdown (Hartley et al. 2020 §VI, state augmentation).

The joint encoders give each foot's position in the base frame by forward kinematics,
s̃_i = fk_i(α̃) (pinocchio, the base at the origin); the filter predicts it from its state as

    s_i = Rᵀ (d_i − p) + n_s,   n_s ~ N(0, σ_s² I)

With R = R̂ Exp(δθ), Rᵀ ≈ (I − [δθ]×) R̂ᵀ, so the Jacobian of s_i in δx is
H_p = −R̂ᵀ, H_θ = [ŝ_i]× (ŝ_i = R̂ᵀ (d̂_i − p̂)), H_d_i = R̂ᵀ, zero elsewhere.

At a touchdown the foot's part of x is made anew where the kinematics put it,
d_i = p + R s̃_i, so δd_i = δp − R̂ [s̃_i]× δθ + R̂ n_s: its rows of the covariance are those
of this map (`touchdown_map`), its own block adds R̂ σ_s² Rᵀ = σ_s² I.
"""

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from lab.estimation.state import ErrorLayout, NominalState


class LegKinematics:
    """Each contact frame's position in the base frame from the joint angles (pinocchio's
    forward kinematics on the robot's free-flyer `model`, the base at the origin)."""

    def __init__(self, model: pin.Model, frames: Sequence[str]) -> None:
        self.model = model
        self.data = model.createData()
        self.frame_ids = tuple(model.getFrameId(frame) for frame in frames)
        self.q = pin.neutral(model)  # base at the origin, upright
        self.v = np.zeros(model.nv)  # the base at rest

    def feet(self, joints: np.ndarray) -> np.ndarray:
        """(n, 3): each foot's position (m, base frame) at joint angles `joints` (rad)."""
        self.q[7:] = joints
        pin.framesForwardKinematics(self.model, self.data, self.q)
        return np.array([self.data.oMf[i].translation for i in self.frame_ids])

    def spins(self, joints: np.ndarray, joint_velocities: np.ndarray) -> np.ndarray:
        """(n, 3): each foot's angular velocity relative to the base (rad/s, base frame) at
        joint angles `joints` and rates `joint_velocities`."""
        self.q[7:], self.v[6:] = joints, joint_velocities
        pin.forwardKinematics(self.model, self.data, self.q, self.v)
        frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        return np.array(
            [pin.getFrameVelocity(self.model, self.data, i, frame).angular for i in self.frame_ids]
        )


def foot_innovation(
    x: NominalState, i: int, measured: np.ndarray, layout: ErrorLayout
) -> tuple[np.ndarray, np.ndarray]:
    """Foot `i`'s residual s̃_i − s_i(x̂) (3,) and its rows of H (3, layout.size)."""
    predicted = x.rotation.T @ (x.feet[i] - x.position)
    H = np.zeros((3, layout.size))
    H[:, layout.p] = -x.rotation.T
    H[:, layout.theta] = pin.skew(predicted)
    H[:, layout.feet[i]] = x.rotation.T
    return measured - predicted, H


def touchdown_map(x: NominalState, measured: np.ndarray, layout: ErrorLayout) -> np.ndarray:
    """The rows (3, layout.size) that give a touching-down foot's δd_i from the rest of δx,
    its kinematics reading `measured` (base frame): [I at δp, −R̂ [s̃]× at δθ]."""
    A = np.zeros((3, layout.size))
    A[:, layout.p] = np.eye(3)
    A[:, layout.theta] = -x.rotation @ pin.skew(measured)
    return A
