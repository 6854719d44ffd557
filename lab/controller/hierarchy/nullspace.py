"""Hierarchical least squares by iterative null-space projection (Hutter 2014, §3).

Each priority i solves its rows as well as it can in the null space of all rows above (eqs. 8–11):

    x ← x + N_i (A_i N_i)⁺ (b_i − A_i x),     N_{i+1} = N_i ∩ null(A_i N_i)

with N_i kept as an orthonormal basis Z (so (A_i Z Zᵀ)⁺ = Z (A_i Z)⁺) and the pseudo-inverse and
the next null space taken from one column-pivoted QR of (A_i Z)ᵀ, the cascade's rank-revealing
step (linalg.least_squares_step: A_i Z = Π R₁ᵀ Q₁ᵀ, (A_i Z)⁺ r = Q₁ (R₁ᵀ)⁺ Πᵀ r, the next Z is
Z Q₂). §3.1 takes an SVD for its robustness near singular tasks; the pivoted QR decides the rank
with one rule, a diagonal entry of R above RANK_RTOL · max(1, |R₀₀|), in both kernels, for a
tenth of the cost. No QP is solved.

Inequality rows C x ≤ d (§3.2, §5.1.3) are off until violated: a violated row becomes the
equality C_j x = d_j at its own level, stacked with the other active rows of that level just above
that level's equalities, and the whole hierarchy is solved again. §3.2 stops there, and the
active set only grows: a row activated on the way stays pinned at its bound where the final
solution would keep it inside, and both bounds of one joint can end up pinned at once
(docs/controller.md has the cases that showed it). So this is a primal active set:
§3.2's activation first (the most violated row of the highest violated level, one per solve,
until none is: activating every violated row at once pinned rows that only the unconstrained
first solution violated, each then released by trial solves), then an
active row is released when the hierarchy solved without it keeps it inside its bound (its
multiplier has the wrong sign; every level is a convex least squares, so an optimum without the
row that satisfies it is the optimum with it), and z steps from where it is towards the optimum of
the new active set only as far as no inactive row gets violated, the row that blocks it being
activated (jumping to that optimum and activating all it violates can cycle between active sets).
A trial whose outcome the solve with the row already gives (`_predicted_violation`: the freed
direction carried down the levels below, exact where its rank decisions are clear-cut) is not
solved when it would keep the row: on G1's unload ticks nearly every trial, ~2/3 of the tick.
A row blocks only when the step would violate it by more than the tolerance a release allows,
ties broken by the smallest index (Bland's rule): rows pinned together and linearly dependent,
such as a contact's normal, CoP and friction rows as its force goes to zero, otherwise cycled,
released at no change of the optimum and re-activated by rounding in the next step.
The search may start from any active rows (`problem.active_start`: the controller passes the last
tick's) and still ends at the same optimum; from a close start in a few solves (a hot start).
Where the start rows' solution violates a row, it walks from a point instead (`problem.x_start`,
the last tick's x, under `qdd_force`), pinning the rows that point violates and those it crosses.

Every hierarchy solve (`_project`) counts against a cap, MAX_PROJECTIONS per call, against
cycling and against ticks far over their budget (docs/controller.md). At the cap the
search stops at the best point it has: the feasible z of the release phase (every inequality
satisfied, some pinned that the optimum would release) or, still activating, the last z; an
`ActiveSetCapWarning` says which (`warnings`: the caller decides how to show it).

The hierarchy can be solved over any vector of §4 (`problem.formulation`, formulations.py).
`sequential` (Table 4) splits it: rows without force terms (motion, joint limits) solve q̈ first
without the dynamics, then the rows with force terms (torque and force objectives, torque
limits, friction) solve τ under the projected dynamics (eq. 49). The x returned is what that τ
does (constrained forward dynamics): when the support set cannot realize the kinematic q̈
(truly under-actuated, Definition 1), q̈ differs from it and the dynamics still hold exactly.

Just over 400 lines: one method, its active-set search and the release prediction the search
calls, read top to bottom in one place as nullspace.cpp mirrors them.
"""

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lab.controller.hierarchy.formulations import (
    constrained_forward_dynamics,
    reparametrize,
    torque_step,
)
from lab.controller.hierarchy.linalg import (
    least_squares_step,
    least_squares_with_residual,
    rank_by_margin,
)
from lab.controller.hierarchy.problem import HierarchyProblem, Level
from lab.controller.hierarchy.solution import PROJECTED, HierarchySolution, level_residuals

ACTIVATION_TOL = 1e-9  # an inequality violated by more than this is activated
RATIO_TIE = 1e-12  # step lengths this close block together (ties, broken by Bland's rule)
# Hierarchy solves per call, at most: against cycling and against ticks far over their budget.
# tests/controller/test_hutter.py (the Hutter 2014 replications) and
# tests/controller/test_nullspace.py use at most
# 121 (measured over their 16,796 calls; p99 18): the cap leaves their results as they were.
MAX_PROJECTIONS = 128
# A release trial decided from the main solve (`_predicted_violation`, not a hierarchy solve, so
# not counted against MAX_PROJECTIONS): ratios below the band's low end count as zero, above its
# high end decide; a predicted violation within RELEASE_MARGIN · max(1, |d_j|) of ACTIVATION_TOL
# runs the trial. benchmarks/release_sensitivity.py measured the gap the band sits in.
RELEASE_BAND = (1e-14, 1e-11)
RELEASE_MARGIN = 1e-6


class ActiveSetCapWarning(RuntimeWarning):
    """The active-set search stopped at MAX_PROJECTIONS before its optimum."""


@dataclass
class ActiveSetSolution:
    """z, how many hierarchy solves it took, and whether the cap stopped the search (then z is
    the best point found: `feasible` says whether it satisfies every inequality)."""

    z: np.ndarray
    projections: int
    capped: bool
    feasible: bool
    active: list[np.ndarray]  # the active rows of each level's C where the search stopped


class _Budget:
    """Counts hierarchy solves against the cap; `ran_out` once one was wanted past it."""

    def __init__(self, cap: int) -> None:
        self.cap, self.used, self.ran_out = cap, 0, False

    def take(self) -> bool:
        """Whether one more solve fits; records running out if not."""
        self.ran_out = self.ran_out or self.used >= self.cap
        return not self.ran_out


def solve_nullspace(problem: HierarchyProblem, solver: str = "daqp") -> HierarchySolution:
    """x = [q̈, F] by iterative null-space projection, every level `projected`, `capped` when an
    active-set search stopped at its cap; `solver` is unused (no QP here)."""
    starts = [*problem.active_start, None, None][:2]
    if problem.formulation == "sequential":
        x, searches = _solve_sequential(problem, starts)
    else:
        change = reparametrize(problem, problem.formulation)
        levels = [change.eom] + [change.level(level) for level in problem.levels]
        # z is x itself under qdd_force: the last tick's x is a point to start from
        point = problem.x_start if problem.formulation == "qdd_force" else None
        search = _searched(levels, change.T.shape[1], starts[0], point)
        x, searches = change.T @ search.z + change.t, (search,)
    statuses = (PROJECTED,) * len(problem.levels)
    return HierarchySolution(
        x,
        statuses,
        level_residuals(problem.levels, x),
        capped=any(search.capped for search in searches),
        active_sets=tuple(search.active for search in searches),
    )


def hierarchical_least_squares(levels: Sequence[Level], n: int) -> np.ndarray:
    """Strict priorities over z ∈ Rⁿ with inequalities activated when violated (§3.1–3.2);
    warns (ActiveSetCapWarning) when the cap stopped the search."""
    return _searched(levels, n).z


def _searched(
    levels: Sequence[Level],
    n: int,
    start: Sequence[np.ndarray] | None = None,
    point: np.ndarray | None = None,
) -> ActiveSetSolution:
    """The active-set search from `start` (and `point`), warning (ActiveSetCapWarning) when the
    cap stopped it."""
    solution = active_set_least_squares(levels, n, start=start, point=point)
    if solution.capped:
        state = "feasible" if solution.feasible else "still violating an inequality"
        warnings.warn(
            f"nullspace: active set stopped at the cap of {MAX_PROJECTIONS} hierarchy solves, at "
            f"the best point found ({state})",
            ActiveSetCapWarning,
            stacklevel=3,
        )
    return solution


def active_set_least_squares(
    levels: Sequence[Level],
    n: int,
    cap: int | None = None,
    start: Sequence[np.ndarray] | None = None,
    point: np.ndarray | None = None,
) -> ActiveSetSolution:
    """The active-set search of `hierarchical_least_squares`, at most `cap` hierarchy solves
    (default MAX_PROJECTIONS), from the active rows `start` (e.g. the last tick's; ignored unless
    they match the levels' rows) or none, and, where those rows' solution violates a row, from
    `point` (e.g. the last tick's z), walking from it to a z that satisfies every row."""
    active = [np.zeros(len(level.d), dtype=bool) for level in levels]
    if start is not None and [len(on) for on in start] == [len(on) for on in active]:
        active = [np.array(on, dtype=bool) for on in start]
    budget = _Budget(MAX_PROJECTIONS if cap is None else cap)
    entry: list[tuple[np.ndarray, np.ndarray]] = []  # (z, Z) on entering each level
    z = _project(levels, active, n, entry, 0, budget)
    if point is not None and len(point) == n and _violates(levels, active, z):
        # A primal start: ticks apart the optimum moves a little while its active rows may jump,
        # and §3.2's activation from the start rows' solution then pinned ~30 rows (Talos's
        # torque limits) that hundreds of trial releases undid. From the last tick's point only
        # the rows it violates and those crossed on the way to the solution get pinned.
        for level, on in zip(levels, active, strict=True):
            on |= level.C @ point - level.d > ACTIVATION_TOL
        target = _project(levels, active, n, entry, 0, budget)
        z = _walked(levels, active, n, entry, budget, point, target)
        if budget.ran_out:
            return ActiveSetSolution(z, budget.used, capped=True, feasible=True, active=active)
    while (k := _activate_violated(levels, active, z)) is not None:  # §3.2
        if not budget.take():
            return ActiveSetSolution(z, budget.used, capped=True, feasible=False, active=active)
        z = _project(levels, active, n, entry, k, budget)
    # z satisfies every inequality from here on: each step stops at the first row it would cross
    while (target := _release_one(levels, active, z, n, entry, budget)) is not None:
        z = _walked(levels, active, n, entry, budget, z, target)
        if budget.ran_out:
            break
    return ActiveSetSolution(z, budget.used, capped=budget.ran_out, feasible=True, active=active)


def _violates(levels: Sequence[Level], active: Sequence[np.ndarray], z: np.ndarray) -> bool:
    """Whether z violates an inactive row by more than ACTIVATION_TOL."""
    return any(
        np.any((level.C @ z - level.d)[~on] > ACTIVATION_TOL)
        for level, on in zip(levels, active, strict=True)
    )


def _walked(
    levels: Sequence[Level],
    active: Sequence[np.ndarray],
    n: int,
    entry: list[tuple[np.ndarray, np.ndarray]],
    budget: _Budget,
    z: np.ndarray,
    target: np.ndarray,
) -> np.ndarray:
    """From z towards `target` (the solution of the active rows), re-solved each time a row
    blocks the way and is activated (`_step`), to the optimum of the active rows where no row
    blocks; where the budget ran out, the point reached."""
    while True:
        z, k = _step(levels, active, z, target)
        if k is None or not budget.take():
            return z
        target = _project(levels, active, n, entry, k, budget)


def _activate_violated(
    levels: Sequence[Level], active: Sequence[np.ndarray], z: np.ndarray
) -> int | None:
    """Activate the most violated row of the highest-priority level that has any (the rule of
    the dual active-set methods, Goldfarb & Idnani 1983); its level's index. Rows violated as
    much within ACTIVATION_TOL (relative) tie, broken by the smallest index (Bland's rule): a
    contact's ±f_t friction rows at f_t = 0 are violated equally, and rounding otherwise picks
    between them (the two kernels took different paths to the same optimum)."""
    for k, (level, on) in enumerate(zip(levels, active, strict=True)):
        excess = np.where(on, 0.0, level.C @ z - level.d)
        worst = excess.max(initial=0.0)
        if worst > ACTIVATION_TOL:
            on[np.flatnonzero(excess >= worst - ACTIVATION_TOL * worst)[0]] = True
            return k
    return None


def _release_one(
    levels: Sequence[Level],
    active: Sequence[np.ndarray],
    z: np.ndarray,
    n: int,
    entry: list[tuple[np.ndarray, np.ndarray]],
    budget: _Budget,
) -> np.ndarray | None:
    """Release the first active row that the hierarchy solved without it keeps inside its bound;
    the hierarchy's solution without it. Each trial reuses the levels above the row's, and is
    skipped where `_predicted_violation` says clearly that it would keep the row. None when no
    row can be released or the budget ran out first."""
    for k, (level, on) in enumerate(zip(levels, active, strict=True)):
        for j in np.flatnonzero(on):
            predicted = _predicted_violation(levels, active, entry, k, int(j))
            margin = RELEASE_MARGIN * max(1.0, abs(level.d[j]))
            if predicted is not None and predicted - ACTIVATION_TOL > margin:
                continue  # kept, as the trial would have kept it: no hierarchy solve
            if not budget.take():
                return None
            on[j] = False
            trial = entry[: k + 1]
            released = _project(levels, active, n, trial, k, budget)
            if level.C[j] @ released - level.d[j] <= ACTIVATION_TOL:
                entry[:] = trial
                return released
            on[j] = True
    return None


def _predicted_violation(
    levels: Sequence[Level],
    active: Sequence[np.ndarray],
    entry: list[tuple[np.ndarray, np.ndarray]],
    k: int,
    j: int,
) -> float | None:
    """C_j z − d_j of the hierarchy solved without active row j of level k, from the solve with
    it (`entry`, its levels' (z, Z)), or None where that is not clear-cut (then the trial runs).

    Exact, not an estimate: releasing j frees one direction, δ = Z (C_on Z)⁺ e_j (C_j δ = 1, the
    other pinned rows unmoved), and the solution is affine in row j's value s,
    z(s) = z* + (s − d_j) δ, δ carried down the sub-levels below each by its least-squares
    correction δ ← δ − Z (M Z)⁺ M δ. The first sub-level whose residual the direction moves,
    g = M δ − M Z (M Z)⁺ M δ ≠ 0, fixes s: the one minimising ‖r − (s − d_j) g‖, r = b − M z its
    residual, s − d_j = gᵀr / gᵀg; the levels below have no say. Whether g ≠ 0 is a rank decision
    (benchmarks/release_sensitivity.py measured it on G1 and Talos): ratios ‖g‖ / (max(1, ‖M Z‖_F)
    max(1, ‖M δ‖)) below RELEASE_BAND[0] are zero, above RELEASE_BAND[1] decide, and one between
    leaves it to the trial, as do pinned rows of level k near dependent (`rank_by_margin`).
    The C++ kernel reuses the main solve's factorizations; this reference solves again."""
    z, Z = entry[k]
    level, on = levels[k], active[k]
    pinned = level.C[on] @ Z
    if Z.shape[1] == 0 or not rank_by_margin(pinned):
        return None
    unit = (np.flatnonzero(on) == j).astype(float)
    coefficients, _, _ = least_squares_with_residual(pinned, unit)
    delta = Z @ coefficients
    Z, z = least_squares_step(Z, z, level.C[on], level.d[on])
    below = [(level.A, level.b)] + [
        pair
        for lower, pinned in zip(levels[k + 1 :], active[k + 1 :], strict=True)
        for pair in ((lower.C[pinned], lower.d[pinned]), (lower.A, lower.b))
    ]
    for M, b in below:
        if len(b) == 0:
            continue
        moved, MZ = M @ delta, M @ Z
        correction, g, _ = least_squares_with_residual(MZ, moved)
        size = max(1.0, float(np.linalg.norm(MZ))) * max(1.0, float(np.linalg.norm(moved)))
        ratio = float(np.linalg.norm(g)) / size
        if ratio > RELEASE_BAND[1]:
            return float(g @ (b - M @ z) / (g @ g))
        if ratio >= RELEASE_BAND[0]:
            return None
        delta = delta - Z @ correction
        if Z.shape[1]:
            Z, z = least_squares_step(Z, z, M, b)
    return None


def _step(
    levels: Sequence[Level], active: Sequence[np.ndarray], z: np.ndarray, target: np.ndarray
) -> tuple[np.ndarray, int | None]:
    """Move from z towards target as far as every inactive row z satisfies stays satisfied;
    activate the row that blocks the move, if one does, and give its level."""
    dz = target - z
    alpha, blocking = 1.0, None
    for k, (level, on) in enumerate(zip(levels, active, strict=True)):
        if len(level.d) == 0:
            continue
        slack = level.d - level.C @ z
        rate = level.C @ dz
        # Blocking only where the step would violate the row by more than ACTIVATION_TOL, the
        # tolerance `_release_one` releases with: a row released at its bound (no change of the
        # optimum, e.g. one of a vanishing contact's CoP, friction and normal rows, all pinned
        # at zero force) is not re-activated by rounding in a step of ~1e-12.
        closing = np.flatnonzero(
            ~on & (slack >= -ACTIVATION_TOL) & (rate * alpha - slack > ACTIVATION_TOL)
        )
        if len(closing):
            ratio = np.maximum(slack[closing] / rate[closing], 0.0)
            # Bland's rule on ties (Nocedal & Wright §13.5, §16.5): the smallest index.
            j = closing[np.flatnonzero(ratio <= ratio.min() + RATIO_TIE)[0]]
            alpha, blocking = float(ratio.min()), (k, j)
    if blocking is None:
        return target, None
    active[blocking[0]][blocking[1]] = True
    return z + alpha * dz, blocking[0]


def _project(
    levels: Sequence[Level],
    active: Sequence[np.ndarray],
    n: int,
    entry: list[tuple[np.ndarray, np.ndarray]],
    first: int,
    budget: _Budget,
) -> np.ndarray:
    """Solve levels `first`, ... from the (z, Z) recorded on entering `first` (levels above
    unchanged since), recording each level's entry in `entry` as it goes; one solve of `budget`."""
    budget.used += 1
    z, Z = (np.zeros(n), np.eye(n)) if first == 0 else entry[first]
    del entry[first:]
    for level, on in zip(levels[first:], active[first:], strict=True):
        entry.append((z, Z))
        for A, b in ((level.C[on], level.d[on]), (level.A, level.b)):
            if len(b) == 0 or Z.shape[1] == 0:
                continue
            Z, z = least_squares_step(Z, z, A, b)  # eqs. 8–11, linalg.py's rank rule
    return z


def _solve_sequential(
    problem: HierarchyProblem, starts: Sequence[Sequence[np.ndarray] | None]
) -> tuple[np.ndarray, tuple[ActiveSetSolution, ActiveSetSolution]]:
    """Hutter Table 4: q̈ first, then τ (module docstring), each search from its start; x and
    the two searches."""
    terms = problem.terms
    if terms is None:
        raise ValueError("formulation 'sequential' needs the model terms of the problem")
    nv = terms.M.shape[0]
    motion_levels, dynamic_levels = [], []
    for level in problem.levels:
        moving = ~np.any(level.A[:, nv:] != 0.0, axis=1)
        limiting = ~np.any(level.C[:, nv:] != 0.0, axis=1)
        motion_levels.append(
            Level(level.A[moving, :nv], level.b[moving], level.C[limiting, :nv], level.d[limiting])
        )
        dynamic_levels.append(
            Level(level.A[~moving], level.b[~moving], level.C[~limiting], level.d[~limiting])
        )
    motion = _searched(motion_levels, nv, starts[0])  # step 1 (eq. 48)
    qdd = motion.z
    change = torque_step(terms, qdd)
    levels = [change.eom] + [change.level(level) for level in dynamic_levels]
    torque = _searched(levels, change.T.shape[1], starts[1])  # step 2 (eqs. 49–51)
    support = terms.Jc[np.flatnonzero(terms.support)]
    x = constrained_forward_dynamics(terms, torque.z, support @ qdd)
    return x, (motion, torque)
