"""Strict priorities as a cascade of QPs with null-space reduction (Herzog 2016, §2.2).

Level 0 is the Newton–Euler rows, solved without a QP (§2.4). Level r then minimises its
equality residual and the slacks of its inequalities over the optimal set of the levels above:

    min_{u, v}  ‖A_r (x* + Z u) − b_r‖² + ‖v‖²                                (eq. 10)
    s.t.        C_r (x* + Z u) − d_r ≤ v                                   (eq. 11)
                C_k (x* + Z u) − d_k ≤ v_k*   for every level k above      (eq. 9)

where Z spans the null space of all equality rows above (eq. 8). Each level shrinks Z by the
directions its equalities lock, and keeps its inequalities with the slack v* it reached.

Strict means exactly lexicographic: a lower level never raises a higher level's cost. The level
QP above is only positive semi-definite in u, and a regularization ε‖·‖² added to it would trade
the level's own residual for a smaller x (with forces of hundreds of newtons the leak reached
1e-2). So a level where an inequality binds is solved in two stages: its optimum first (the QP
as it is, semi-definite: DAQP solves it by its own proximal iterations, Clarabel by its interior
point; only a level the solver wrongly fails is solved again with a proximal term ε‖u − u₀‖²,
from each optimum until the level's A_r Z u settles, so that the term vanishes), then,
inside that level's optimal set {A_r Z u = A_r Z u*, C_r(x* + Z u) − d_r ≤ v*}, the point with
the smallest ‖x* + Z u‖, which leaves the most room to the levels below (Herzog eq. 5).

Forces of contacts out of support are zero, like the dynamics, above every level: the cascade
drops them from Z at level 0 instead of carrying their bounds through every level.

Most ticks no inequality binds. The cascade then first solves the equality rows alone, one least
squares per level, and keeps that x when it satisfies every inequality of the stack: each level
has then reached its unconstrained optimum with zero slack, which is the strict solution. Only
otherwise does it run the QPs level by level.
"""

from dataclasses import dataclass

import numpy as np

from lab.controller.hierarchy.linalg import (
    least_squares_and_null_space,
    least_squares_step,
    solution_and_null_space_of_leading_block,
)
from lab.controller.hierarchy.problem import HierarchyProblem
from lab.controller.hierarchy.solution import (
    EXACT,
    KEPT_ABOVE,
    NO_FREEDOM,
    QP,
    HierarchySolution,
    LevelClock,
    level_residuals,
)
from lab.controller.qp import QPFailure, solve_qp

# ε of the cascade's proximal term ε‖u − u₀‖²: none. The level QP's Hessian (A_r Z)ᵀ A_r Z
# (eqs. 10–11) is semi-definite, and DAQP solves such a QP by its own proximal loop (its automatic
# eps_prox), to the optimum in one call. A cascade-side ε (1e-10 until round 18) sat at the
# rounding level of the 10⁴-weighted rows' pivots, so DAQP ran its proximal loop inside each of
# the cascade's 2–8 proximal solves; one loop (with LEVEL_ETA_PROX) takes 16 % fewer
# instructions on G1's unload ticks, 21 % on Talos with arms' (docs/performance.md, round 18).
REGULARIZATION = 0.0
# A level with one or two equality rows in a null space of ten dimensions leaves its Hessian with
# few non-zero eigenvalues; DAQP then sometimes reports a level infeasible although u = 0 is
# feasible by construction. Such a level is solved again once with this ε, by proximal solves.
RETRY_REGULARIZATION = 1e-6
# DAQP's proximal loop stops when no x moves by more than eta_prox / eps in a step: its automatic
# eta left a level 7e-8 above its optimum (tests/controller/test_controller.py), 1e-8 too; 3e-9
# and below reach it. Only the level QPs (the weighted method's QP keeps DAQP's own).
LEVEL_ETA_PROX = 1e-9
FEASIBILITY_TOL = 1e-9  # an unconstrained step that violates no row by more is taken as is
ZERO_ROW_TOL = 1e-10  # a kept inequality with no freedom left in Z is dropped from the QP


@dataclass
class _Record:
    """How each level was solved, as the cascade goes: statuses, QP count, time per level."""

    levels: list[str]
    clock: LevelClock
    qp_solves: int = 0

    def solution(self, problem: HierarchyProblem, x: np.ndarray) -> HierarchySolution:
        return HierarchySolution(
            x,
            tuple(self.levels),
            level_residuals(problem.levels, x),
            self.qp_solves,
            tuple(self.clock.seconds),
        )


def solve_cascade(problem: HierarchyProblem, solver: str = "daqp") -> HierarchySolution:
    """The strict-priority solution x = [q̈, F] with each level's status. Every level is feasible
    (u = 0 keeps the levels above), so a level whose QP the solver fails keeps the solution of
    the levels above: its status is `kept_above` (HierarchySolution.fallback_levels)."""
    n = len(problem.levels)
    record = _Record([EXACT] * n, LevelClock(n))
    x = _equalities_only(problem, record.clock)
    if all(
        (level.C @ x <= level.d + FEASIBILITY_TOL).all() for level in problem.levels if len(level.d)
    ):
        return record.solution(problem, x)
    return record.solution(problem, _with_inequalities(problem, solver, record))


def _dynamics_solution(problem: HierarchyProblem) -> tuple[np.ndarray, np.ndarray]:
    """Z and x of level 0: the Newton–Euler rows, with no force on a contact out of support."""
    Zx = solution_and_null_space_of_leading_block(problem.dynamics_A, problem.dynamics_b)
    Z, x = Zx[:, :-1], Zx[:, -1]
    if problem.terms is None or problem.terms.support.all():
        return Z, x
    # Z's columns past the base are the joint accelerations, then the forces.
    nj = Z.shape[1] - len(problem.terms.support)
    return Z[:, np.concatenate((np.ones(nj, dtype=bool), problem.terms.support))], x


def _equalities_only(problem: HierarchyProblem, clock: LevelClock) -> np.ndarray:
    """The cascade of the equality rows alone: one least squares and null space per level."""
    Z, x = _dynamics_solution(problem)
    clock.start()
    for depth, level in enumerate(problem.levels):
        if len(level.b) and Z.shape[1]:
            Z, x = least_squares_step(Z, x, level.A, level.b)
        clock.lap(depth)
    return x


def _with_inequalities(problem: HierarchyProblem, solver: str, record: _Record) -> np.ndarray:
    """The cascade of eqs. 9–11, one QP per level where an inequality binds."""
    Z, x = _dynamics_solution(problem)
    record.clock.start()
    # Inequalities of the levels above, kept as their rows over x (C_above) with the room k each
    # has left within the slack its level reached (eq. 9): in null-space coordinates they are
    # C_above Z u ≤ k, a product formed only for a level that poses a QP (the others need
    # C_above (Z u) alone). k ≥ 0 always holds, so u = 0 is feasible for every level whatever
    # the solver tolerance of the levels before.
    C_above = np.zeros((0, len(x)))
    k = np.zeros(0)
    last = len(problem.levels) - 1
    for depth, level in enumerate(problem.levels):
        if Z.shape[1] == 0:
            record.levels[depth:] = [NO_FREEDOM] * (len(problem.levels) - depth)
            break
        Az, r = _projected(level.A, level.b, Z, x)
        s = level.d - level.C @ x
        u, N = least_squares_and_null_space(Az, r)
        # When the least-squares step violates no inequality, (u, v = 0) is optimal. Without
        # equalities that step is u = 0, which the carried bounds always allow (k ≥ 0).
        step = Z @ u
        if (level.C @ step <= s + FEASIBILITY_TOL).all() and (
            C_above @ step <= k + FEASIBILITY_TOL
        ).all():
            record.levels[depth] = EXACT
        else:
            K = C_above @ Z
            free = (K * K).sum(axis=1) > ZERO_ROW_TOL**2
            rows = _LevelRows(Az, r, N, level.C @ Z, s, K[free], k[free])
            u = _solve_level(u, rows, Z, x, solver, record, depth)
            step = Z @ u
        x = x + step
        record.clock.lap(depth)
        if depth == last:
            break
        if len(s):
            C_above = np.concatenate((C_above, level.C))
            k = np.concatenate([k, s])
        k = np.maximum(k - C_above @ step, 0.0)
        if len(r):  # lock the directions this level's equalities used (eq. 8)
            Z = Z @ N
    return x


def _projected(
    A: np.ndarray, b: np.ndarray, Z: np.ndarray, x: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Rows A x = b (or ≤ b) in null-space coordinates: A Z u against b − A x."""
    if not len(b):
        return np.zeros((0, Z.shape[1])), b
    return A @ Z, b - A @ x


@dataclass(frozen=True)
class _LevelRows:
    """One level in the null-space coordinates u of the levels above (x = x* + Z u): its
    equalities Az u = r with their null space N, its inequalities Cz u ≤ s, and the carried
    inequalities K u ≤ k of the levels above that still have freedom in Z."""

    Az: np.ndarray
    r: np.ndarray
    N: np.ndarray
    Cz: np.ndarray
    s: np.ndarray
    K: np.ndarray
    k: np.ndarray


def _solve_level(
    u: np.ndarray,
    rows: _LevelRows,
    Z: np.ndarray,
    x: np.ndarray,
    solver: str,
    record: _Record,
    depth: int,
) -> np.ndarray:
    """The step in the null space for one level whose least-squares step u violates an
    inequality (the slacks are implicit in the cost); records the level's status in `record`."""
    Az, r, Cz, s, Kz, k = rows.Az, rows.r, rows.Cz, rows.s, rows.K, rows.k
    nz, m = Az.shape[1], len(s)
    # Over (u, v): C u − v ≤ s (the level's rows with their slacks), K u ≤ k (the carried rows).
    G = np.zeros((m + len(k), nz + m))
    G[:m, :nz] = Cz
    G[:m, nz:] = -np.eye(m)
    G[m:, :nz] = Kz
    h = np.concatenate([s, k])
    for epsilon in (REGULARIZATION, RETRY_REGULARIZATION):
        try:
            optimum = _level_optimum(u, Az, r, G, h, epsilon, solver, record)
        except QPFailure:
            continue
        record.levels[depth] = QP
        return _smallest_in_optimal_set(optimum, rows, Z, x, solver, record)
    # u = 0 is feasible by construction, so this is the solver failing, not the level. Seen when
    # the carried bounds leave the level no freedom (a feasible set of 1e-9 about u = 0, more
    # tight rows than directions): DAQP then reports it infeasible. The level keeps the solution
    # of the levels above, and says so (HierarchySolution.fallback_levels).
    record.levels[depth] = KEPT_ABOVE
    return np.zeros(nz)


# Proximal solves of one level: each starts at the last one's optimum, so the ε term vanishes
# as they converge. A lower level's cost moves to first order with the level's A_r Z u while the
# level's own cost moves only to second order, so the solves go on until A_r Z u has settled.
PROXIMAL_SOLVES = 8
PROXIMAL_TOL = 1e-10  # relative change of A_r Z u at which the level's optimum has settled


def _level_optimum(
    u: np.ndarray,
    Az: np.ndarray,
    r: np.ndarray,
    G: np.ndarray,
    h: np.ndarray,
    epsilon: float,
    solver: str,
    record: _Record,
) -> np.ndarray:
    """A minimiser of ‖Az u − r‖² + ‖v‖² over G [u; v] ≤ h (eqs. 10–11): one solve at ε = 0,
    else proximal steps ε‖u − u₀‖² from the least-squares step u (exact where a fixed ε‖u‖²
    would leak)."""
    nz, m = Az.shape[1], G.shape[1] - Az.shape[1]
    P = np.zeros((nz + m, nz + m))
    P[:nz, :nz] = Az.T @ Az + epsilon * np.eye(nz)
    P[nz:, nz:] = np.eye(m)
    q = np.zeros(nz + m)
    w = Az @ u
    for _ in range(PROXIMAL_SOLVES):
        q[:nz] = -Az.T @ r - epsilon * u
        record.qp_solves += 1
        u = solve_qp(P, q, G, h, solver=solver, eta_prox=LEVEL_ETA_PROX)[:nz]
        if epsilon == 0.0:
            break  # no term to vanish: the solver's own proximal loop reached the optimum
        w, previous = Az @ u, w
        if np.linalg.norm(w - previous) <= PROXIMAL_TOL * (1.0 + np.linalg.norm(w)):
            break
    return u


def _smallest_in_optimal_set(
    u: np.ndarray, rows: _LevelRows, Z: np.ndarray, x: np.ndarray, solver: str, record: _Record
) -> np.ndarray:
    """Among the optimal steps u + N w of a level (same Az u, slacks no larger than u's, carried
    bounds kept), the one with the smallest ‖x + Z (u + N w)‖ (Herzog eq. 5)."""
    N = rows.N
    if N.shape[1] == 0:
        return u
    ZN = Z @ N
    # Bounds of w: each row keeps the room it has at u (≥ 0: w = 0 is feasible).
    G = np.concatenate((rows.Cz @ N, rows.K @ N))
    h = np.maximum(np.concatenate((rows.s - rows.Cz @ u, rows.k - rows.K @ u)), 0.0)
    free = (G * G).sum(axis=1) > ZERO_ROW_TOL**2
    G, h = G[free], h[free]
    record.qp_solves += 1
    try:
        w = solve_qp(ZN.T @ ZN, ZN.T @ (x + Z @ u), G, h, solver=solver)
    except QPFailure:
        return u  # still optimal for the level; only the smallest x among its optima is lost
    # The solver's tolerance may overstep a row the level's optimum already sits on: step back
    # along w until every row is within its room again (w = 0 always is).
    rate = G @ w
    over = rate > h
    if over.any():
        w = w * min(1.0, float(np.min(h[over] / rate[over])))
    smallest: np.ndarray = u + N @ w
    return smallest
