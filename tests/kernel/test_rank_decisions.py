"""Both kernels decide the rank of a level's rows the same way (issue 27 item 6), under the
cascade and under nullspace (round 12): LAPACK's `dgeqp3` in Python (hierarchy/linalg.py) and
Eigen's pivoted QR in C++ (cpp/hierarchy/linalg.cpp) count the diagonal entries of R above the
same threshold, RANK_RTOL · max(1, |R₀₀|). On matrices
built with singular values on either side of it, both find the intended rank, the same null
space and the same least-squares step."""

import numpy as np
import pytest

from lab.controller.hierarchy.linalg import RANK_RTOL, least_squares_and_null_space
from lab.controller.hierarchy.nullspace import active_set_least_squares
from lab.controller.hierarchy.problem import Level
from lab.controller.native import NOT_BUILT

if NOT_BUILT:
    pytest.skip(NOT_BUILT, allow_module_level=True)
from lab import _kernel

# A pivoted QR's diagonal follows the singular values within a small factor at these sizes (it
# is not equal to them): a singular value 30 times above or below the threshold is on the same
# side of it for both QRs. Measured over these draws: |R_kk| / σ_k within 0.36–2.5 (dgeqp3).
MARGIN = 30.0
# Relative: the two steps solve the same full-rank triangular system in another float order; the
# step's size grows as 1 / σ_min ≤ 1 / (MARGIN · RANK_RTOL), so rounding is amplified up to ~3e7.
STEP_RTOL = 1e-6
# nullspace's z against the intended rank's truncated SVD, relative to 1 + |z|: over these draws
# the right rank is within 0.4 of it, one rank more or less 12 times it or more (measured).
INTENDED_RTOL = 3.0 / MARGIN**2


def near_rank_deficient(
    rng: np.random.Generator, rows: int, cols: int, rank: int, scale: float
) -> np.ndarray:
    """A (rows × cols) with `rank` ≥ 1 singular values from `scale` down to MARGIN · RANK_RTOL ·
    max(1, scale) and the rest MARGIN times below that threshold (not zero: near deficient)."""
    threshold = RANK_RTOL * max(1.0, scale)
    k = min(rows, cols)
    kept = np.geomspace(scale, MARGIN * threshold, rank)
    dropped = np.full(k - rank, threshold / MARGIN) * rng.uniform(0.1, 1.0, k - rank)
    U, _ = np.linalg.qr(rng.normal(size=(rows, k)))
    V, _ = np.linalg.qr(rng.normal(size=(cols, k)))
    return U @ np.diag(np.concatenate([kept, dropped])) @ V.T


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])  # |R₀₀| below and above 1: max(1, ·)
def test_both_kernels_find_the_same_rank_null_space_and_step(scale: float) -> None:
    assert _kernel.rank_rtol == RANK_RTOL
    rng = np.random.default_rng(5)
    cases = 0
    for rows, cols in ((3, 12), (6, 18), (12, 12), (20, 14)):
        for rank in range(1, min(rows, cols) + 1, 2):
            A = near_rank_deficient(rng, rows, cols, rank, scale)
            b = A @ rng.normal(size=cols) + 1e-3 * rng.normal(size=rows)
            u, N = least_squares_and_null_space(A, b)
            u_native, N_native = _kernel.least_squares_and_null_space(A, b)
            what = f"{rows}x{cols} rank {rank} scale {scale:g}"
            assert N.shape[1] == cols - rank, f"python: {what}"
            assert N_native.shape[1] == cols - rank, f"native: {what}"
            # the same null space: each basis's projector is the other's
            assert np.allclose(N @ N.T, N_native @ N_native.T, atol=1e-9), what
            assert np.linalg.norm(u_native - u) <= STEP_RTOL * (1.0 + np.linalg.norm(u)), what
            cases += 1
    assert cases == 2 + 3 + 6 + 7


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_the_nullspace_method_decides_each_levels_rank_the_same_in_both_kernels(
    scale: float,
) -> None:
    """nullspace's level step is the same pivoted QR (nullspace.py via linalg.py's
    least_squares_step, nullspace.cpp via RowSpaceQR): a near rank-deficient level above an
    objective z = c over every coordinate. With the intended rank r, z is the level's minimum-norm
    step plus c projected on its null space, as the level's truncated SVD gives it (to the
    1 / MARGIN² tilt a QR's truncation leaves between the kept and dropped directions); one rank
    more or less moves z by the step along a dropped direction (≥ MARGIN / threshold) or by a
    kept direction's share of c, which b pulls the other way. Both kernels give that z, and the
    same z."""
    rng = np.random.default_rng(7)
    cases = 0
    for rows, cols in ((3, 12), (6, 18), (12, 12), (20, 14)):
        for rank in range(1, min(rows, cols), 2):  # a null space left for the objective
            A = near_rank_deficient(rng, rows, cols, rank, scale)
            c = rng.normal(size=cols)
            b = -(A @ c) + 1e-3 * rng.normal(size=rows)  # the level pulls against c
            level = Level(A, b, np.zeros((0, cols)), np.zeros(0))
            objective = Level(np.eye(cols), c, np.zeros((0, cols)), np.zeros(0))
            z = active_set_least_squares([level, objective], cols).z
            rows_of = [(lv.A, lv.b, lv.C, lv.d) for lv in (level, objective)]
            z_native = _kernel.active_set_search(rows_of, cols)[0]
            U, sigma, Vt = np.linalg.svd(A)
            V = Vt[:rank].T
            intended = V @ ((U[:, :rank].T @ b) / sigma[:rank]) + c - V @ (V.T @ c)
            what = f"{rows}x{cols} rank {rank} scale {scale:g}"
            size = 1.0 + np.linalg.norm(intended)
            assert np.linalg.norm(z - intended) <= INTENDED_RTOL * size, f"python: {what}"
            assert np.linalg.norm(z_native - z) <= STEP_RTOL * (1.0 + np.linalg.norm(z)), what
            cases += 1
    assert cases == 1 + 3 + 6 + 7
