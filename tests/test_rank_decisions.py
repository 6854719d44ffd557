"""Both kernels decide the rank of a level's rows the same way (issue 27 item 6): LAPACK's
`dgeqp3` in Python (hierarchy/linalg.py) and Eigen's pivoted QR in C++ (cpp/hierarchy/linalg.cpp)
count the diagonal entries of R above the same threshold, RANK_RTOL · max(1, |R₀₀|). On matrices
built with singular values on either side of it, both find the intended rank, the same null
space and the same least-squares step."""

import numpy as np
import pytest

from lab.controller.hierarchy.linalg import RANK_RTOL, least_squares_and_null_space
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
