"""The small dense-algebra steps of the cascade, each a direct LAPACK call.

At these sizes (tens of rows) numpy's wrappers cost more than the factorizations themselves, and
an SVD costs ten times a QR: everything here comes from one column-pivoted QR per level.
"""

from functools import cache

import numpy as np
from scipy.linalg import lapack

RANK_RTOL = 1e-9
RANK_MARGIN = 1e3  # a rank decision by this factor off the threshold is safe from rounding


class SingularSystem(np.linalg.LinAlgError):
    """A system that should be positive definite or invertible was not."""


def solution_and_null_space_of_leading_block(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """[Z | x] for A = [A₁ A₂] with A₁ square and invertible: x solves A x = b, Z spans null(A).

    x = [A₁⁻¹ b; 0] and Z = [−A₁⁻¹ A₂; I]: one small solve instead of an SVD. The Newton–Euler
    rows have this form, A₁ being the base block of M (Herzog §2.4, footnote 3). Z is not
    orthonormal; the cascade only needs it to span the null space (eq. 8). Returned side by side
    so that one product moves both to the next level.
    """
    k, n = A.shape
    rhs = np.empty((k, n - k + 1), order="F")  # [−A₂ | b]
    np.negative(A[:, k:], out=rhs[:, :-1])
    rhs[:, -1] = b
    _, _, solved, info = lapack.dgesv(A[:, :k], rhs, overwrite_b=1)
    if info != 0:
        raise SingularSystem("the base block of the mass matrix is singular")
    Zx = _identity_below(n, k).copy()
    Zx[:k] = solved
    return Zx


@cache
def _identity_below(n: int, k: int) -> np.ndarray:
    """[0; I | 0]: an n × (n − k + 1) block with the identity under its first k rows."""
    block = np.zeros((n, n - k + 1))
    block[k:, :-1] = np.eye(n - k)
    block.flags.writeable = False
    return block


def least_squares_and_null_space(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The minimum-norm minimiser u of ‖A u − b‖ and an orthonormal basis N of null(A).

    One column-pivoted QR of Aᵀ: Aᵀ Π = [Q₁ Q₂] [R₁; 0], with R₁ holding the `rank` rows whose
    diagonal exceeds RANK_RTOL · max(1, |R₀₀|). Then A ≈ Π R₁ᵀ Q₁ᵀ, so u = Q₁ y with y the least-
    squares solution of R₁ᵀ y = Πᵀ b, and N = Q₂. Rows that are zero up to round-off (a level with
    no freedom left) count as locked and give u = 0, not a step divided by round-off.
    """
    m, n = A.shape
    if m == 0:
        return np.zeros(n), np.eye(n)
    qr, pivots, tau, rank = _pivoted_qr_of_transpose(A)
    reflectors = np.zeros((n, n), order="F")
    reflectors[:, : len(tau)] = qr[:, : len(tau)]
    Q, _, info = lapack.dorgqr(reflectors, tau, overwrite_a=1)
    if info:
        raise SingularSystem("forming Q of a level's rows failed")
    if rank == 0:
        return np.zeros(n), Q
    return Q[:, :rank] @ _triangular_solve(qr, pivots, b, rank), Q[:, rank:]


def least_squares_step(
    Z: np.ndarray, x: np.ndarray, A: np.ndarray, b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """One equality level of the cascade: x + Z u and Z N, without forming Q or N.

    u and N are those of `least_squares_and_null_space(A Z, b − A x)`. With A Z = Π R₁ᵀ Q₁ᵀ,
    u = Q₁ y and N = Q₂, so x + Z u = x + (Z Q)₁ y and Z N = (Z Q)₂: one `dormqr` applies the
    reflectors to Z directly (Herzog eq. 8 for the new basis).
    """
    AZ = A @ Z
    qr, pivots, tau, rank = _pivoted_qr_of_transpose(AZ)
    if rank == 0:
        return Z, x
    ZQ, _, info = lapack.dormqr("R", "N", qr[:, : len(tau)], tau, Z, _WORK_PER_ROW * len(Z))
    if info:
        raise SingularSystem("applying Q of a level's rows failed")
    y = _triangular_solve(qr, pivots, b - A @ x, rank)
    return ZQ[:, rank:], x + ZQ[:, :rank] @ y


def least_squares_with_residual(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """u, g and the rank: u the minimum-norm minimiser of ‖A u − b‖ and g = b − Π R₁ᵀ Q₁ᵀ u the part
    of b outside A's range, both by the rank rule (`least_squares_and_null_space`'s QR; rows the
    rule drops count as zero). A may have no columns (then u is empty and g is b)."""
    m, n = A.shape
    if n == 0:
        return np.zeros(0), b.copy(), 0
    qr, pivots, tau, rank = _pivoted_qr_of_transpose(A)
    if rank == 0:
        return np.zeros(n), b.copy(), 0
    y = _triangular_solve(qr, pivots, b, rank)
    g = np.empty(m)
    g[pivots - 1] = b[pivots - 1] - np.triu(qr[:rank, :m]).T @ y  # Πᵀ b − R₁ᵀ y, unpermuted
    padded = np.zeros((n, 1))
    padded[:rank, 0] = y
    u, _, info = lapack.dormqr("L", "N", qr[:, : len(tau)], tau, padded, _WORK_PER_ROW * n)
    if info:
        raise SingularSystem("applying Q of a level's rows failed")
    return u[:, 0], g, rank


def rank_by_margin(A: np.ndarray) -> bool:
    """Whether A (rows ≤ columns) has full row rank with every diagonal entry of its pivoted QR
    RANK_MARGIN times above the rank rule's threshold (no rank decision near the threshold)."""
    qr, _, _, rank = _pivoted_qr_of_transpose(A)
    diagonal = np.abs(qr.diagonal())
    return rank == len(A) and diagonal[-1] > RANK_MARGIN * RANK_RTOL * max(1.0, diagonal[0])


def _pivoted_qr_of_transpose(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """`dgeqp3` of Aᵀ (R and the reflectors in one array, pivots, reflector scales) and the rank."""
    qr, pivots, tau, _, info = lapack.dgeqp3(A.T)
    if info:
        raise SingularSystem("the pivoted QR of a level's rows failed")
    # Column pivoting makes |R₀₀| ≥ |R₁₁| ≥ …: the rank is the count above the threshold.
    diagonal = np.abs(qr.diagonal())
    rank = int(np.count_nonzero(diagonal > RANK_RTOL * max(1.0, diagonal[0])))
    return qr, pivots, tau, rank


def _triangular_solve(qr: np.ndarray, pivots: np.ndarray, b: np.ndarray, rank: int) -> np.ndarray:
    """y solving R₁ᵀ y = Πᵀ b, in the least-squares sense when there are more rows than rank."""
    m = len(b)
    rhs = b[pivots - 1]  # Πᵀ b
    if rank == m:  # R₁ᵀ is square and lower triangular (dtrtrs reads only R's upper triangle)
        y, info = lapack.dtrtrs(qr, rhs, trans=1)
    else:  # more rows than freedom: least squares of the full-column-rank R₁ᵀ
        _, y, info = lapack.dgels(qr[:rank, :m].T * _lower(m, rank), rhs)
        y = y[:rank]
    if info:
        raise SingularSystem("the triangular solve of a level's rows failed")
    return y


_WORK_PER_ROW = 64  # dormqr's workspace: a block of reflectors per row of Z


@cache
def _lower(m: int, n: int) -> np.ndarray:
    """Mask of the lower trapezoid of an m × n matrix (read-only, shared)."""
    mask = np.tri(m, n)
    mask.flags.writeable = False
    return mask
