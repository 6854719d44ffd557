"""Hierarchy solvers on randomized problems: strict priority, dynamics, inequalities, backends."""

from pathlib import Path

import numpy as np
import pytest

from lab.controller.hierarchy import METHODS, HierarchyProblem, Level, cascade
from lab.controller.hierarchy.cascade import solve_cascade
from lab.controller.hierarchy.linalg import (
    least_squares_and_null_space,
    least_squares_step,
    least_squares_with_residual,
    rank_by_margin,
)
from lab.controller.hierarchy.problem import DynamicsTerms
from lab.controller.hierarchy.weighted import solve_weighted
from lab.controller.qp import QPFailure

NX = 24
EQUALITY_TOL = 1e-8  # residuals of exact equalities and of equality-only strict priority
SOLVER_TOL = 1e-6  # DAQP's primal tolerance: inequalities and priority with active inequalities
BACKEND_TOL = 1e-5  # DAQP vs Clarabel (at 1e-8 gap and feasibility), relative to |x|
SEEDS = range(12)


def random_rows(rng: np.random.Generator, rows: int, rank: int) -> np.ndarray:
    """Rows of the given rank with singular values in [0.5, 2], like a task Jacobian."""
    U = np.linalg.qr(rng.standard_normal((rows, rank)))[0]
    V = np.linalg.qr(rng.standard_normal((NX, rank)))[0]
    return U @ np.diag(rng.uniform(0.5, 2.0, rank)) @ V.T


def dynamics(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    A = rng.standard_normal((6, NX))
    A[:, :6] += 5 * np.eye(6)  # like the base block of M: square and invertible
    return A, rng.standard_normal(6)


def empty_inequalities() -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((0, NX)), np.zeros(0)


def equality_problem(rng: np.random.Generator, levels: int) -> HierarchyProblem:
    # Level sizes over-determine the 18 free variables, so lower levels conflict with higher ones.
    shapes = [(8, 8), (6, 5), (10, 10), (12, 12)][:levels]
    return HierarchyProblem(
        *dynamics(rng),
        [
            Level(random_rows(rng, m, r), rng.standard_normal(m), *empty_inequalities())
            for m, r in shapes
        ],
    )


def with_inequalities(rng: np.random.Generator, levels: int) -> HierarchyProblem:
    """Hard limits above equality levels, as friction and torque limits sit above the tasks.

    Level 1 holds only inequalities, feasible with the dynamics but cut through the unconstrained
    optimum; the lowest equality level gets inequalities of its own too (soft against its tasks).
    """
    problem = equality_problem(rng, levels)
    x_free = solve_cascade(problem).x
    C = rng.standard_normal((8, NX))
    spread = np.abs(C @ x_free).mean()
    d = C @ x_free + np.where(np.arange(8) % 2 == 0, -0.5, 0.5) * spread
    limits = Level(np.zeros((0, NX)), np.zeros(0), C, d)
    C_low = rng.standard_normal((4, NX))
    problem.levels[-1].C, problem.levels[-1].d = C_low, C_low @ x_free - 0.3 * spread
    problem.levels.insert(0, limits)
    return problem


def residual(level: Level, x: np.ndarray) -> float:
    return float(np.linalg.norm(level.A @ x - level.b))


def truncated(problem: HierarchyProblem, levels: int) -> HierarchyProblem:
    return HierarchyProblem(problem.dynamics_A, problem.dynamics_b, problem.levels[:levels])


@pytest.mark.parametrize("seed", SEEDS)
def test_lower_levels_never_change_a_higher_residual_equalities(seed: int) -> None:
    problem = equality_problem(np.random.default_rng(seed), 4)
    full = solve_cascade(problem).x
    for k in range(1, 4):
        alone = solve_cascade(truncated(problem, k)).x
        for level in problem.levels[:k]:
            assert abs(residual(level, full) - residual(level, alone)) <= EQUALITY_TOL


@pytest.mark.parametrize("seed", SEEDS)
def test_first_level_reaches_its_least_squares_optimum(seed: int) -> None:
    problem = equality_problem(np.random.default_rng(seed), 3)
    x = solve_cascade(problem).x
    # Independent reference: least squares of level 1 over the affine set of the dynamics.
    A0, b0 = problem.dynamics_A, problem.dynamics_b
    x0 = np.linalg.lstsq(A0, b0, rcond=None)[0]
    Z = np.linalg.svd(A0)[2][6:].T
    level = problem.levels[0]
    u = np.linalg.lstsq(level.A @ Z, level.b - level.A @ x0, rcond=None)[0]
    best = residual(level, x0 + Z @ u)
    assert residual(level, x) <= best + EQUALITY_TOL
    assert np.linalg.norm(A0 @ x - b0) <= EQUALITY_TOL


@pytest.mark.parametrize("seed", SEEDS)
def test_priority_holds_with_active_inequalities(seed: int) -> None:
    problem = with_inequalities(np.random.default_rng(seed), 3)
    full = solve_cascade(problem).x
    for k in (2, 3):
        alone = solve_cascade(truncated(problem, k)).x
        for level in problem.levels[1:k]:
            assert abs(residual(level, full) - residual(level, alone)) <= SOLVER_TOL
    # The limits of level 1 are above every task: they hold to the solver tolerance.
    limits = problem.levels[0]
    assert np.all(limits.C @ full - limits.d <= SOLVER_TOL)
    assert np.linalg.norm(problem.dynamics_A @ full - problem.dynamics_b) <= EQUALITY_TOL


@pytest.mark.parametrize("seed", SEEDS)
def test_inequalities_bind_the_solution(seed: int) -> None:
    """The inequalities of the test problems do change the answer: the checks above are not idle."""
    problem = with_inequalities(np.random.default_rng(seed), 3)
    limits = problem.levels[0]
    without_limits = HierarchyProblem(problem.dynamics_A, problem.dynamics_b, problem.levels[1:])
    free = solve_cascade(without_limits).x
    assert np.max(limits.C @ free - limits.d) > 1e-2


@pytest.mark.parametrize("method", sorted(set(METHODS) - {"wbosc"}))  # wbosc solves no QP
@pytest.mark.parametrize("seed", SEEDS)
def test_daqp_and_clarabel_agree(method: str, seed: int) -> None:
    problem = with_inequalities(np.random.default_rng(seed), 3)
    x_daqp = METHODS[method](problem, "daqp").x
    x_clarabel = METHODS[method](problem, "clarabel").x
    assert np.linalg.norm(x_daqp - x_clarabel) <= BACKEND_TOL * max(1.0, np.linalg.norm(x_daqp))


@pytest.mark.parametrize("seed", SEEDS)
def test_weighted_dynamics_and_inequalities_are_hard(seed: int) -> None:
    problem = with_inequalities(np.random.default_rng(seed), 3)
    x = solve_weighted(problem).x
    assert np.linalg.norm(problem.dynamics_A @ x - problem.dynamics_b) <= SOLVER_TOL
    for level in problem.levels:
        assert np.all(level.C @ x - level.d <= SOLVER_TOL)  # hard in one QP, whatever the level


@pytest.mark.parametrize("seed", SEEDS)
def test_weighted_approaches_strict_as_weight_ratio_grows(seed: int) -> None:
    # Fully determined (6 + 8 + 10 independent directions = NX), so the strict answer is unique,
    # and level 2 over-determines its 10 directions: the two levels conflict.
    rng = np.random.default_rng(seed)
    problem = HierarchyProblem(
        *dynamics(rng),
        [
            Level(random_rows(rng, 8, 8), rng.standard_normal(8), *empty_inequalities()),
            Level(random_rows(rng, 16, 16), rng.standard_normal(16), *empty_inequalities()),
        ],
    )
    strict = solve_cascade(problem).x
    gaps = []
    for ratio in (1e2, 1e4, 1e6):
        problem.levels[1].weight = 1 / ratio
        gaps.append(np.linalg.norm(solve_weighted(problem, "daqp").x - strict))
    assert gaps[0] > gaps[1] > gaps[2]
    assert gaps[2] <= 1e-3 * np.linalg.norm(strict)


@pytest.mark.parametrize(
    ("rows", "cols", "rank"), [(12, 24, 12), (24, 6, 6), (24, 6, 3), (5, 10, 3), (6, 6, 0)]
)
def test_one_qr_gives_the_minimum_norm_least_squares_step_and_the_null_space(
    rows: int, cols: int, rank: int
) -> None:
    rng = np.random.default_rng(rows + cols + rank)
    A = rng.standard_normal((rows, rank)) @ rng.standard_normal((rank, cols))
    b = rng.standard_normal(rows)
    u, N = least_squares_and_null_space(A, b)
    assert np.allclose(u, np.linalg.pinv(A, rcond=1e-9) @ b, atol=EQUALITY_TOL)
    assert N.shape == (cols, cols - rank)
    assert np.allclose(A @ N, 0.0, atol=EQUALITY_TOL)
    assert np.allclose(N.T @ N, np.eye(cols - rank), atol=EQUALITY_TOL)


@pytest.mark.parametrize(
    ("rows", "cols", "rank"),
    [(12, 24, 12), (24, 6, 6), (24, 6, 3), (5, 10, 3), (6, 6, 0), (4, 0, 0)],
)
def test_the_least_squares_residual_is_the_part_of_b_outside_the_range(
    rows: int, cols: int, rank: int
) -> None:
    """u is the minimum-norm minimiser and g = b − A u its residual, orthogonal to A's range (the
    release prediction's g); full row rank by the margin exactly where rank = rows."""
    rng = np.random.default_rng(rows + cols + rank)
    A = rng.standard_normal((rows, rank)) @ rng.standard_normal((rank, cols))
    b = rng.standard_normal(rows)
    u, g, found = least_squares_with_residual(A, b)
    assert found == rank and u.shape == (cols,)
    assert np.allclose(u, np.linalg.pinv(A, rcond=1e-9) @ b, atol=EQUALITY_TOL)
    assert np.allclose(g, b - A @ u, atol=EQUALITY_TOL)
    assert np.allclose(A.T @ g, 0.0, atol=EQUALITY_TOL)
    if cols:
        assert rank_by_margin(A) == (rank == rows)


@pytest.mark.parametrize(("rows", "rank"), [(12, 12), (24, 10), (5, 3), (6, 0)])
def test_a_least_squares_step_moves_x_and_shrinks_the_null_space_like_the_explicit_qr(
    rows: int, rank: int
) -> None:
    rng = np.random.default_rng(rows + rank)
    Z = np.linalg.qr(rng.standard_normal((NX, 14)))[0] @ rng.standard_normal((14, 14))
    x = rng.standard_normal(NX)
    A = rng.standard_normal((rows, rank)) @ rng.standard_normal((rank, NX))
    b = rng.standard_normal(rows)
    Z_next, x_next = least_squares_step(Z, x, A, b)
    u, N = least_squares_and_null_space(A @ Z, b - A @ x)
    assert np.allclose(x_next, x + Z @ u, atol=EQUALITY_TOL)
    assert Z_next.shape == (Z @ N).shape
    # The same subspace: each basis lies in the span of the other.
    assert np.allclose(Z_next @ np.linalg.lstsq(Z_next, Z @ N, rcond=None)[0], Z @ N)
    assert np.allclose(A @ Z_next, 0.0, atol=EQUALITY_TOL)


def test_a_level_without_freedom_keeps_the_solution_above() -> None:
    """A pushed Talos, saved from a run: the carried bounds leave the posture level a feasible set
    of ~1e-9 about u = 0 (16 tight rows in a 14-dimensional null space), which DAQP reports
    infeasible. The cascade must still return the solution of the levels above."""
    data = np.load(Path(__file__).parent.parent / "data" / "talos_pushed_problem.npz")
    count = sum(name.startswith("level") and name.endswith("_A") for name in data.files)
    levels = [Level(*(data[f"level{i}_{k}"] for k in "AbCd")) for i in range(count)]
    terms = DynamicsTerms(data["M"], data["h"], data["Jc"], data["support"])
    problem = HierarchyProblem(data["dynamics_A"], data["dynamics_b"], levels, terms)
    above = HierarchyProblem(problem.dynamics_A, problem.dynamics_b, levels[:-1], terms)
    x, x_above = solve_cascade(problem).x, solve_cascade(above).x
    assert np.abs(problem.dynamics_A @ x - problem.dynamics_b).max() < EQUALITY_TOL
    # The limits of level 0 hold as well as they can (the push leaves them a slack of ~1e-6).
    slack = (levels[0].C @ x_above - levels[0].d).max()
    assert (levels[0].C @ x - levels[0].d).max() <= max(slack, 0.0) + SOLVER_TOL
    for level in levels[1:-1]:
        assert residual(level, x) == pytest.approx(residual(level, x_above), rel=1e-6)


@pytest.mark.parametrize("seed", SEEDS[:4])
def test_the_solution_says_how_each_level_was_solved(seed: int) -> None:
    """Level statuses, residuals and QP count: equalities alone are `exact` with no QP; a problem
    whose inequalities bind runs QPs; residuals are each level's ‖A x − b‖ at x."""
    rng = np.random.default_rng(seed)
    exact = solve_cascade(equality_problem(rng, 3))
    assert exact.levels == ("exact",) * 3 and exact.qp_solves == 0 and exact.status == "ok"
    problem = with_inequalities(np.random.default_rng(seed), 3)  # 4 levels: limits on top
    solution = solve_cascade(problem)
    assert "qp" in solution.levels and solution.qp_solves >= 1 and solution.status == "ok"
    for level, residual in zip(problem.levels, solution.residuals, strict=True):
        expected = np.linalg.norm(level.A @ solution.x - level.b) if len(level.b) else 0.0
        assert residual == pytest.approx(expected, abs=1e-12)
    assert len(solution.level_seconds) == len(problem.levels)
    weighted = solve_weighted(problem)
    assert weighted.levels == ("qp",) * 4 and weighted.qp_solves == 1


def test_a_level_whose_qp_fails_is_reported_as_a_fallback(monkeypatch: pytest.MonkeyPatch) -> None:
    """The cascade's u = 0 fallback is not silent: the level is `kept_above` and the solution's
    status `fallback`; the dynamics still hold exactly."""
    problem = with_inequalities(np.random.default_rng(0), 3)
    healthy = solve_cascade(problem)
    first_qp = healthy.levels.index("qp")

    def failing(*args: object, **kwargs: object) -> np.ndarray:
        raise QPFailure("made to fail")

    monkeypatch.setattr(cascade, "solve_qp", failing)
    solution = solve_cascade(problem)
    assert solution.status == "fallback"
    assert solution.fallback_levels[0] == first_qp
    assert solution.levels[first_qp] == "kept_above"
    assert solution.summary()["fallback_levels"] == list(solution.fallback_levels)
    dynamics_residual = problem.dynamics_A @ solution.x - problem.dynamics_b
    assert np.linalg.norm(dynamics_residual) <= EQUALITY_TOL
