"""The optimization vectors of Hutter 2014 §4, as changes of variables of one hierarchy.

Every hierarchy method here receives rows over x = [q̈, F] (Table 3, the projected Newton–Euler
rows on top). A formulation solves the same hierarchy over another vector z, with x an affine
function x = T z + t of it and its own equations of motion as the highest priority:

- `qdd_force`  z = [q̈, F]        (Table 3): P_S [M, −J_sᵀ] z = −P_S h, the problem's own rows.
- `full`       z = [q̈, τ, F]     (Table 1): [M, −Sᵀ, −J_sᵀ] z = −h.
- `qdd_tau`    z = [q̈, τ]        (Table 2): Q_uᵀ [M, −Sᵀ] z = −Q_uᵀ h, and F from eq. 28.
- `sequential` q̈ first, then τ   (Table 4): see nullspace.py.

Signs follow the lab's convention M q̈ + h − J_sᵀ F = Sᵀ τ (F acts on the robot), so eq. 28 reads
F_s = R⁻¹ Q_cᵀ (M q̈ + h − Sᵀ τ) with J_sᵀ = Q [R; 0], Q = [Q_c Q_u] (a QR of the support
Jacobian). Forces of contacts out of support are held at zero by the equations of motion.
A row a x = b of any level becomes (a T) z = b − a t: a torque objective written over [q̈, F]
through τ(x) = M_a q̈ + h_a − J_aᵀ F equals W τ = b_τ on the equations of motion, a force
objective W F = b_F becomes eq. 35–36 under `qdd_tau`, and so on.
"""

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from lab.controller.hierarchy.linalg import RANK_RTOL, SingularSystem
from lab.controller.hierarchy.problem import DynamicsTerms, HierarchyProblem, Level
from lab.controller.model import BASE_DOF

FORMULATIONS = ("qdd_force", "full", "qdd_tau", "sequential")


@dataclass
class Reparametrization:
    """x = T z + t, with the formulation's equations of motion `eom` as rows over z."""

    T: np.ndarray
    t: np.ndarray
    eom: Level

    def level(self, level: Level) -> Level:
        """The same rows over z."""
        return Level(
            level.A @ self.T,
            level.b - level.A @ self.t,
            level.C @ self.T,
            level.d - level.C @ self.t,
        )


@dataclass
class SupportQR:
    """J_sᵀ = Q_c R (Q_u spans the rest); `force_map` K gives F = K (M q̈ + h − Sᵀ τ), eq. 28."""

    Qc: np.ndarray
    Qu: np.ndarray
    force_map: np.ndarray


def support_qr(terms: DynamicsTerms) -> SupportQR:
    """The QR decomposition of the support Jacobian (Hutter §4.2.1); raises when it is singular."""
    nv, nf = terms.M.shape[0], terms.Jc.shape[0]
    support = np.flatnonzero(terms.support)
    Q, R = scipy.linalg.qr(terms.Jc[support].T, check_finite=False)
    k = len(support)
    diagonal = np.abs(np.diagonal(R[:k, :k]))
    if k and diagonal.min() <= RANK_RTOL * max(1.0, diagonal.max()):
        raise SingularSystem("the support Jacobian is singular (feet in a singular stance)")
    K = np.zeros((nf, nv))
    K[support] = scipy.linalg.solve_triangular(R[:k, :k], Q[:, :k].T, check_finite=False)
    return SupportQR(Q[:, :k], Q[:, k:], K)


def unsupported_forces_rows(terms: DynamicsTerms, nz: int, offset: int) -> Level:
    """F_j = 0 for every force row out of support, F starting at column `offset` of z."""
    free = np.flatnonzero(~terms.support)
    A = np.zeros((len(free), nz))
    A[np.arange(len(free)), offset + free] = 1.0
    return Level(A, np.zeros(len(free)), np.zeros((0, nz)), np.zeros(0))


def reparametrize(problem: HierarchyProblem, formulation: str) -> Reparametrization:
    """The change of variables of `formulation` (one of qdd_force, full, qdd_tau)."""
    nx, terms = problem.nx, problem.terms
    if formulation == "qdd_force":
        eom = Level(problem.dynamics_A, problem.dynamics_b, np.zeros((0, nx)), np.zeros(0))
        if terms is not None:
            zero = unsupported_forces_rows(terms, nx, terms.M.shape[0])
            eom = Level(np.vstack([eom.A, zero.A]), np.concatenate([eom.b, zero.b]), eom.C, eom.d)
        return Reparametrization(np.eye(nx), np.zeros(nx), eom)
    if terms is None:
        raise ValueError(f"formulation {formulation!r} needs the model terms of the problem")
    M, h, Jc = terms.M, terms.h, terms.Jc
    nv, nf = M.shape[0], Jc.shape[0]
    na = nv - BASE_DOF
    St = np.zeros((nv, na))  # Sᵀ
    St[BASE_DOF:] = np.eye(na)
    if formulation == "full":
        nz = nv + na + nf
        zero = unsupported_forces_rows(terms, nz, nv + na)
        eom = Level(
            np.vstack([np.hstack([M, -St, -Jc.T]), zero.A]),
            np.concatenate([-h, zero.b]),
            np.zeros((0, nz)),
            np.zeros(0),
        )
        T = np.zeros((nx, nz))
        T[:nv, :nv] = np.eye(nv)
        T[nv:, nv + na :] = np.eye(nf)
        return Reparametrization(T, np.zeros(nx), eom)
    if formulation == "qdd_tau":
        qr = support_qr(terms)
        MS = np.hstack([M, -St])
        eom = Level(qr.Qu.T @ MS, -qr.Qu.T @ h, np.zeros((0, nv + na)), np.zeros(0))
        T = np.zeros((nx, nv + na))
        T[:nv, :nv] = np.eye(nv)
        T[nv:] = qr.force_map @ MS
        t = np.zeros(nx)
        t[nv:] = qr.force_map @ h
        return Reparametrization(T, t, eom)
    raise ValueError(f"unknown formulation {formulation!r} (formulations: {FORMULATIONS})")


def torque_step(terms: DynamicsTerms, qdd: np.ndarray) -> Reparametrization:
    """Step 2 of the sequential method (Table 4): z = τ with q̈ fixed.

    Equations of motion Q_uᵀ Sᵀ τ = Q_uᵀ (M q̈ + h) (eq. 49); x = [q̈; F(τ)] by eq. 28, so a force
    row becomes eq. 58–59 and a torque row written through τ(x) stays W τ on the dynamics.
    """
    M, h = terms.M, terms.h
    nv = M.shape[0]
    na = nv - BASE_DOF
    qr = support_qr(terms)
    bias = M @ qdd + h
    eom = Level(
        qr.Qu[BASE_DOF:].T, qr.Qu.T @ bias, np.zeros((0, na)), np.zeros(0)
    )  # Q_uᵀ Sᵀ = rows of Q_u at the actuated coordinates, transposed
    T = np.zeros((nv + len(terms.support), na))
    T[nv:] = -qr.force_map[:, BASE_DOF:]
    t = np.concatenate([qdd, qr.force_map @ bias])
    return Reparametrization(T, t, eom)


def constrained_forward_dynamics(
    terms: DynamicsTerms, tau: np.ndarray, contact_acceleration: np.ndarray
) -> np.ndarray:
    """x = [q̈, F] that τ produces with the support feet at the given accelerations J_s q̈.

    Solves [M −J_sᵀ; J_s 0] [q̈; F_s] = [Sᵀ τ − h; J_s q̈_kin]: exact dynamics, whatever q̈_kin was.
    """
    M, h, Jc = terms.M, terms.h, terms.Jc
    nv = M.shape[0]
    support = np.flatnonzero(terms.support)
    Js = Jc[support]
    k = len(support)
    K = np.zeros((nv + k, nv + k))
    K[:nv, :nv], K[:nv, nv:], K[nv:, :nv] = M, -Js.T, Js
    rhs = np.concatenate([-h, contact_acceleration])
    rhs[BASE_DOF:nv] += tau
    solution = scipy.linalg.solve(K, rhs, check_finite=False)
    x = np.zeros(nv + Jc.shape[0])
    x[:nv] = solution[:nv]
    x[nv + support] = solution[nv:]
    return x
