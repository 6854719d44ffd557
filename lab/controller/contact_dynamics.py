"""Contact-consistent dynamics of a floating-base robot (Kim 2016 App. A, eqs. 27–32).

With the feet in support held still (J_s q̈ + J̇_s v = 0), the joint torques τ determine q̈ and
the reaction forces in closed form. Everything here is in the lab's conventions: M q̈ + h −
J_sᵀ F = Uᵀ τ with F the force of the ground *on* the robot, so Kim's λ (the force on the
environment) is −F.
"""

from dataclasses import dataclass

import numpy as np

from lab.controller.model import BASE_DOF

# Relative size below which an eigenvalue of Φ* (or of a task's Λ*⁻¹) counts as zero.
RANK_TOLERANCE = 1e-9


def psd_pinv(matrix: np.ndarray, scale: float | None = None) -> tuple[np.ndarray, int]:
    """Pseudo-inverse of a symmetric positive semi-definite matrix and its rank: eigenvalues
    below RANK_TOLERANCE times `scale` (default: the largest eigenvalue) count as zero. A
    projected matrix passes the scale of the unprojected one, so that what the projection
    removed (to rounding) is not inverted."""
    inverse, null_space = _psd_pinv_and_null_space(matrix, scale)
    return inverse, matrix.shape[0] - null_space.shape[1]


def _psd_pinv_and_null_space(
    matrix: np.ndarray, scale: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """`psd_pinv`'s pseudo-inverse and an orthonormal basis (columns) of the null space."""
    if matrix.size == 0:
        return np.zeros_like(matrix), np.zeros((len(matrix), 0))
    values, vectors = np.linalg.eigh(0.5 * (matrix + matrix.T))
    keep = values > RANK_TOLERANCE * max(values[-1] if scale is None else scale, 1e-300)
    inverse = (vectors[:, keep] / values[keep]) @ vectors[:, keep].T
    return inverse, vectors[:, ~keep]


@dataclass(frozen=True)
class ContactDynamics:
    """The maps of eqs. 28–32 at one state, for the supporting contacts' rows J_s.

    `qdd_of_torque` (nv × na) and `qdd_free` give q̈ = B τ + q̈₀ (eq. 30); `force_of_torque`
    (n_s × na) and `force_free` give the support forces F = D τ + F₀ (eq. 29, F = −λ);
    `inertia_inverse` is A⁻¹; `phi` is Φ* = U N_s A⁻¹ N_sᵀ Uᵀ, `phi_pinv` its pseudo-inverse
    and `internal_basis` (na × k) an orthonormal basis of its null space: the torques that
    move nothing and only change the internal forces (the range of L* = I − U N_s (U N_s)‾, eq. 38).
    """

    inertia_inverse: np.ndarray
    qdd_of_torque: np.ndarray
    qdd_free: np.ndarray
    force_of_torque: np.ndarray
    force_free: np.ndarray
    phi: np.ndarray
    phi_pinv: np.ndarray
    internal_basis: np.ndarray

    def contact_consistent_jacobian(self, J: np.ndarray) -> np.ndarray:
        """J* = J (U N_s)‾ (eq. 33), the task Jacobian over the actuated joints: J B = J* Φ*."""
        j_star: np.ndarray = J @ self.qdd_of_torque @ self.phi_pinv
        return j_star


def contact_dynamics(
    M: np.ndarray, h: np.ndarray, Js: np.ndarray, drift: np.ndarray
) -> ContactDynamics:
    """The contact-consistent maps for inertia M, bias forces h (Coriolis + gravity), support
    Jacobian Js (rows of the feet in support, may be empty) and its drift J̇_s v."""
    nv = M.shape[0]
    Minv = np.linalg.inv(M)
    if len(Js):
        Lambda_s, _ = psd_pinv(Js @ Minv @ Js.T)  # Λ_s = (J_s A⁻¹ J_sᵀ)⁻¹
        Jbar = Minv @ Js.T @ Lambda_s  # J̄_s, eq. 31
        Ns = np.eye(nv) - Jbar @ Js  # eq. 32
    else:
        Lambda_s, Jbar, Ns = np.zeros((0, 0)), np.zeros((nv, 0)), np.eye(nv)
    B = Minv @ Ns.T[:, BASE_DOF:]  # A⁻¹ N_sᵀ Uᵀ: τ → q̈ (eq. 30)
    qdd_free = -Minv @ (Ns.T @ h + Js.T @ (Lambda_s @ drift))
    phi = Ns[BASE_DOF:] @ B
    phi_pinv, internal_basis = _psd_pinv_and_null_space(phi)
    # λ = J̄_sᵀ (Uᵀτ − h) + Λ_s J̇_s v (eq. 29) and F = −λ.
    force_of_torque = -Jbar[BASE_DOF:].T
    force_free = Jbar.T @ h - Lambda_s @ drift
    return ContactDynamics(
        Minv, B, qdd_free, force_of_torque, force_free, phi, phi_pinv, internal_basis
    )
