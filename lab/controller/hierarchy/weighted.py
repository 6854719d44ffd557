"""All levels in one weighted QP (Raiola 2020, stack S1).

    min_x  Σ_r w_r ‖A_r x − b_r‖² + ε‖x‖²   s.t.  dynamics rows exact,  every C_r x ≤ d_r

w_r is the level's weight, on top of the task weights already folded into its rows: weights
that fall by a large ratio from one level to the next approach the strict cascade, equal weights
treat every task by its own weight alone. Inequalities are hard here: none is traded off. The
forces of contacts out of support are zero: their columns leave the QP (the native kernel does
the same), as the other methods hold them at zero, whether or not the stack has `friction`.
"""

import numpy as np

from lab.controller.hierarchy.problem import HierarchyProblem
from lab.controller.hierarchy.solution import QP, HierarchySolution, LevelClock, level_residuals
from lab.controller.qp import QPFailure, solve_qp

REGULARIZATION = 1e-9


def solve_weighted(problem: HierarchyProblem, solver: str = "daqp") -> HierarchySolution:
    """The weighted solution x = [q̈, F] (every level `qp`: one QP for all, its time charged to
    the first level); raises QPFailure when the QP has none."""
    clock = LevelClock(len(problem.levels))
    nx = problem.nx
    lightest = min((level.weight for level in problem.levels), default=1.0)
    H = REGULARIZATION * lightest * np.eye(nx)
    g = np.zeros(nx)
    for level in problem.levels:
        H += level.weight * level.A.T @ level.A
        g -= level.weight * level.A.T @ level.b
    C = np.vstack([np.zeros((0, nx))] + [level.C for level in problem.levels])
    d = np.concatenate([np.zeros(0)] + [level.d for level in problem.levels])
    A, b = problem.dynamics_A, problem.dynamics_b
    terms = problem.terms
    if terms is None or terms.support.all():
        x = solve_qp(H, g, C, d, A, b, solver=solver)
    else:  # the forces out of support are zero: their columns leave the QP (as in the kernel)
        keep = np.concatenate((np.ones(terms.M.shape[0], dtype=bool), terms.support))
        C = C[:, keep]
        rows = np.any(C != 0.0, axis=1)  # rows on those forces only now read 0 ≤ d
        if np.any(d[~rows] < 0.0):
            raise QPFailure("the weighted QP is infeasible: a bound on a force out of support")
        x = np.zeros(nx)
        x[keep] = solve_qp(
            H[np.ix_(keep, keep)], g[keep], C[rows], d[rows], A[:, keep], b, solver=solver
        )
    if problem.levels:
        clock.lap(0)
    levels = (QP,) * len(problem.levels)
    residuals = level_residuals(problem.levels, x)
    return HierarchySolution(x, levels, residuals, qp_solves=1, level_seconds=tuple(clock.seconds))
