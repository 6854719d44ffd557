"""The small dense-algebra steps of the cascade, each a direct LAPACK call.

At these sizes (tens of rows) numpy's wrappers cost more than the factorizations themselves.
"""

from functools import cache

import numpy as np
from scipy.linalg import lapack

RANK_RTOL = 1e-9


class SingularSystem(np.linalg.LinAlgError):
    """A system that should be positive definite or invertible was not."""


def solution_and_null_space_of_leading_block(
    A: np.ndarray, b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """A solution of A x = b and a basis Z of null(A), for A = [A₁ A₂] with A₁ square, invertible.

    x = [A₁⁻¹ b; 0] and Z = [−A₁⁻¹ A₂; I]: one small solve instead of an SVD. The Newton–Euler
    rows have this form, A₁ being the base block of M (Herzog §2.4, footnote 3). Z is not
    orthonormal; the cascade only needs it to span the null space (eq. 8).
    """
    k, n = A.shape
    _, _, solved, info = lapack.dgesv(A[:, :k], np.column_stack([b, A[:, k:]]))
    if info != 0:
        raise SingularSystem("the base block of the mass matrix is singular")
    x = np.zeros(n)
    x[:k] = solved[:, 0]
    Z = np.zeros((n, n - k))
    Z[:k] = -solved[:, 1:]
    Z[k:] = np.eye(n - k)
    return x, Z


def null_space(A: np.ndarray) -> np.ndarray:
    """Orthonormal basis of null(A), from a column-pivoted (rank-revealing) QR of Aᵀ."""
    m, n = A.shape
    if m == 0:
        return np.eye(n)
    qr, _, tau, _, _ = lapack.dgeqp3(A.T)
    k = min(m, n)
    diagonal = np.abs(np.diagonal(qr)[:k])
    rank = int(np.sum(diagonal > RANK_RTOL * max(1.0, diagonal[0])))
    reflectors = np.zeros((n, n))
    reflectors[:, :k] = qr[:, :k]
    Q, _, _ = lapack.dorgqr(reflectors, tau[:k])
    return Q[:, rank:]


def least_squares(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The minimum-norm minimiser of ‖A u − b‖ (rank-revealing QR, no regularization bias).

    Directions whose singular value is below RANK_RTOL · max(1, σ_max) count as locked, as in
    `null_space`: rows that are zero up to round-off (a level with no freedom left) give u = 0,
    not a step divided by round-off.
    """
    m, n = A.shape
    scale = float(np.sqrt((A * A).sum()))  # ≥ σ_max, within √rank of it
    if m == 0 or scale <= RANK_RTOL:
        return np.zeros(n)
    rcond = RANK_RTOL * max(1.0, scale) / scale
    rhs = np.zeros(max(m, n))
    rhs[:m] = b
    _, u, _, _, info = lapack.dgelsy(
        A, rhs, np.zeros(n, dtype=np.int32), rcond, lwork=_least_squares_work(m, n)
    )
    if info != 0:
        raise SingularSystem("least squares did not converge")
    return u[:n]


@cache
def _least_squares_work(m: int, n: int) -> int:
    return int(lapack.dgelsy_lwork(m, n, 1, RANK_RTOL)[0])
