"""The QP backend, through qpsolvers: DAQP for the loop, Clarabel as the reference."""

import numpy as np
import qpsolvers
from scipy import sparse

SOLVERS = ("daqp", "clarabel")
SPARSE_SOLVERS = ("clarabel",)  # take CSC matrices (interior point on a sparse KKT system)

# Clarabel is the reference for cross-checks, so it runs at tight tolerances. DAQP (an active-set
# method) is exact up to its primal tolerance, 1e-6 by default; the cascade solves a level where
# an inequality binds more than once (its optimum, then the smallest x inside it), and at 1e-6
# a Talos sole's CoP row ended 1.02e-6 outside. At 1e-9 it ends within 3e-10.
SOLVER_OPTIONS: dict[str, dict[str, float]] = {
    "daqp": {"primal_tol": 1e-9},
    "clarabel": {"tol_gap_abs": 1e-8, "tol_gap_rel": 1e-8, "tol_feas": 1e-8},
}


class QPFailure(RuntimeError):
    """The backend found no solution (infeasible, or it gave up)."""


def solve_qp(
    P: np.ndarray,
    q: np.ndarray,
    G: np.ndarray | None = None,
    h: np.ndarray | None = None,
    A: np.ndarray | None = None,
    b: np.ndarray | None = None,
    solver: str = "daqp",
    eta_prox: float | None = None,
) -> np.ndarray:
    """min ½ xᵀPx + qᵀx  s.t.  Gx ≤ h, Ax = b; raise QPFailure when there is no solution.

    `eta_prox`: DAQP's stopping tolerance of its own proximal loop on a semi-definite P (None:
    DAQP's automatic one; other solvers have no such loop and ignore it)."""
    if G is not None and len(G) == 0:
        G = h = None
    if A is not None and len(A) == 0:
        A = b = None
    if solver in SPARSE_SOLVERS:
        P, G, A = (None if M is None else sparse.csc_matrix(M) for M in (P, G, A))
    options = dict(SOLVER_OPTIONS[solver])
    if solver == "daqp" and eta_prox is not None:
        options["eta_prox"] = eta_prox
    x = qpsolvers.solve_qp(P, q, G, h, A, b, solver=solver, **options)
    if x is None or not np.all(np.isfinite(x)):
        raise QPFailure(f"{solver} found no solution")
    return x
