"""The nullspace method and its four formulations against cascade and weighted (Hutter 2014 §3–4).

Problems are the controller's own rows for ANYmal at random states. Stated expectations:
- strict stacks (lower levels conflict with higher ones): nullspace in every formulation and the
  cascade give the same q̈ and τ (both are exact strict hierarchies);
- feasible stacks (every level satisfiable at once, x unique): every method gives the same x;
- sequential with two feet (truly under-actuated): the kinematic q̈ cannot be realized, so its
  x differs; it still satisfies the dynamics, and the formulations that keep the dynamics on top
  track the motion level at least as well;
- torque limits: activated-when-violated rows hold the limit like the cascade's slacks do, but
  the cascade's lexicographic optimum tracks the level below at least as well.
"""

from pathlib import Path

import numpy as np
import pytest

from lab.controller.behaviours.balance import standing_references
from lab.controller.controller import ControllerConfig, WholeBodyController
from lab.controller.hierarchy import METHODS, HierarchyProblem, Level, nullspace
from lab.controller.hierarchy.cascade import solve_cascade
from lab.controller.hierarchy.formulations import (
    FORMULATIONS,
    Reparametrization,
    reparametrize,
)
from lab.controller.hierarchy.nullspace import (
    ActiveSetCapWarning,
    active_set_least_squares,
    hierarchical_least_squares,
    solve_nullspace,
)
from lab.controller.hierarchy.problem import DynamicsTerms
from lab.controller.model import RobotModel
from lab.controller.stack import Stack
from lab.controller.tasks import TaskGains
from lab.description import load_description
from lab.robot import build_robot
from tests.helpers.unload import UNLOAD_TICKS, g1_unload_searches

AGREE_TOL = 1e-6  # q̈ (rad/s², m/s²) and τ (N m), the cross-check tolerance
DYNAMICS_TOL = 1e-8
# One weighted QP holds the lowest level (weight 1e-6 after two ratios of 1e3) only to DAQP's
# accuracy: q̈ agrees to AGREE_TOL, but the internal forces it picks, hence τ, to this.
WEIGHTED_TAU_TOL = 1e-4
CASCADE_QP_TOL = 1e-3  # the cascade's DAQP levels: motion residual accuracy with active limits
GAINS = {
    "com": TaskGains(100.0, 20.0),
    "base_orientation": TaskGains(400.0, 40.0),
    "posture": TaskGains(100.0, 20.0),
}
STRICT = [["contact"], ["com", "base_orientation"], ["posture"], ["torques"]]


@pytest.fixture(scope="module")
def anymal() -> tuple[RobotModel, np.ndarray, np.ndarray]:
    robot = build_robot(load_description("anymal"))
    return RobotModel(robot.model, robot.contacts), robot.q_standing, robot.torque_limits


def controller(anymal, stack, active, seed, torque_limits=None) -> WholeBodyController:
    model, q_standing, limits = anymal
    refs = standing_references(model, q_standing)
    refs.contact_active = np.array(active)
    c = WholeBodyController(
        model,
        refs,
        ControllerConfig(Stack.of(stack), gains=dict(GAINS)),
        limits if torque_limits is None else torque_limits,
    )
    rng = np.random.default_rng(seed)
    q = q_standing.copy()
    q[7:] += 0.05 * rng.standard_normal(model.na)
    model.update(q, 0.3 * rng.standard_normal(model.nv))
    return c


def with_swing_forces_pinned(problem: HierarchyProblem) -> HierarchyProblem:
    """The same problem for methods without model terms: F = 0 out of support, on level 1.

    The formulations hold those forces at zero with the dynamics; cascade and weighted need rows.
    """
    terms, nv = problem.terms, problem.terms.M.shape[0]
    free = np.flatnonzero(~terms.support)
    pin_rows = np.zeros((len(free), problem.nx))
    pin_rows[np.arange(len(free)), nv + free] = 1.0
    top = problem.levels[0]
    levels = [
        Level(
            np.vstack([top.A, pin_rows]), np.concatenate([top.b, np.zeros(len(free))]), top.C, top.d
        ),
        *problem.levels[1:],
    ]
    return HierarchyProblem(problem.dynamics_A, problem.dynamics_b, levels)


def solutions(c: WholeBodyController, problem: HierarchyProblem) -> dict[str, np.ndarray]:
    out = {"cascade": solve_cascade(with_swing_forces_pinned(problem), "daqp").x}
    for formulation in FORMULATIONS:
        problem.formulation = formulation
        out[formulation] = solve_nullspace(problem).x
    return out


def assert_same_motion_and_torque(model: RobotModel, x: np.ndarray, reference: np.ndarray) -> None:
    nv = model.nv
    assert np.max(np.abs(x[:nv] - reference[:nv])) <= AGREE_TOL
    assert np.max(np.abs(model.joint_torques(x) - model.joint_torques(reference))) <= AGREE_TOL


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("active", [(True, True, True, True), (True, True, False, True)])
def test_strict_stacks_agree_across_formulations_and_cascade(anymal, seed, active) -> None:
    # With four feet the motion levels fix q̈ and leave posture no freedom: merged with torques.
    stack = [*STRICT[:2], ["posture", "torques"]] if all(active) else STRICT
    c = controller(anymal, stack, active, seed)
    xs = solutions(c, c.build_problem())
    for name, x in xs.items():
        assert_same_motion_and_torque(c.robot, x, xs["qdd_force"]), name


@pytest.mark.parametrize("seed", range(3))
def test_feasible_stacks_agree_across_every_method(anymal, seed) -> None:
    c = controller(anymal, STRICT, (True, True, False, True), seed)
    problem = c.build_problem()
    x_ref = solve_nullspace(problem).x
    for level in problem.levels:  # every level satisfiable at x_ref, x_ref the only solution
        level.b = level.A @ x_ref
    xs = solutions(c, problem)
    problem.formulation = "qdd_force"
    for name, x in xs.items():
        assert_same_motion_and_torque(c.robot, x, x_ref), name
    weighted = METHODS["weighted"](with_swing_forces_pinned(problem), "daqp").x
    model = c.robot
    assert np.max(np.abs(weighted[: model.nv] - x_ref[: model.nv])) <= AGREE_TOL
    tau_error = model.joint_torques(weighted) - model.joint_torques(x_ref)
    assert np.max(np.abs(tau_error)) <= WEIGHTED_TAU_TOL


def test_sequential_differs_by_design_on_two_feet(anymal) -> None:
    c = controller(anymal, STRICT, (True, False, False, True), seed=5)  # LF and RH: a trot
    problem = c.build_problem()
    xs = solutions(c, problem)
    model = c.robot
    for name in ("cascade", "full", "qdd_tau"):
        assert_same_motion_and_torque(model, xs[name], xs["qdd_force"])
    sequential = xs["sequential"]
    assert np.max(np.abs(sequential[: model.nv] - xs["qdd_force"][: model.nv])) > 1e-3
    residual = problem.dynamics_A @ sequential - problem.dynamics_b
    assert np.max(np.abs(residual)) <= DYNAMICS_TOL  # what τ does, with the feet held
    motion = problem.levels[1]
    kept = np.linalg.norm(motion.A @ xs["qdd_force"] - motion.b)
    lost = np.linalg.norm(motion.A @ sequential - motion.b)
    assert kept + 1e-9 < lost


def test_torque_limits_activated_when_violated(anymal) -> None:
    stack = [["contact"], ["torque_limits"], ["com", "base_orientation"], ["posture", "torques"]]
    free = controller(anymal, stack, (True,) * 4, seed=1)
    knees = np.array([2, 5, 8, 11])
    unlimited = free.robot.joint_torques(solve_nullspace(free.build_problem()).x)
    limits = np.full(12, 80.0)
    limits[knees] = 0.6 * np.abs(unlimited[knees]).max()
    c = controller(anymal, stack, (True,) * 4, seed=1, torque_limits=limits)
    problem = c.build_problem()
    xs = solutions(c, problem)
    model, motion = c.robot, problem.levels[2]
    for name in ("cascade", "qdd_force", "full", "qdd_tau"):
        tau = model.joint_torques(xs[name])
        assert np.all(np.abs(tau) <= limits + AGREE_TOL), name
        assert np.max(np.abs(problem.dynamics_A @ xs[name] - problem.dynamics_b)) <= 1e-6
    assert np.max(np.abs(model.joint_torques(xs["qdd_force"])[knees])) >= limits[2] - AGREE_TOL
    # Here the activated rows leave the motion feasible: the other joints take the knees' load
    # and the motion is exact, as the cascade's lexicographic optimum (to its QP accuracy).
    lexicographic = np.linalg.norm(motion.A @ xs["cascade"] - motion.b)
    activated = np.linalg.norm(motion.A @ xs["qdd_force"] - motion.b)
    assert activated <= DYNAMICS_TOL
    assert lexicographic <= activated + CASCADE_QP_TOL
    # Sequential puts the limits under the motion (Table 4): the motion is that of no limits.
    free_problem = free.build_problem()
    free_problem.formulation = "sequential"
    assert np.max(np.abs(xs["sequential"][:18] - solve_nullspace(free_problem).x[:18])) <= 1e-9


def test_without_model_terms_only_the_own_variables_work() -> None:
    rng = np.random.default_rng(0)
    A = rng.standard_normal((6, 12))
    A[:, :6] += 5 * np.eye(6)
    problem = HierarchyProblem(
        A,
        rng.standard_normal(6),
        [
            Level(
                rng.standard_normal((8, 12)), rng.standard_normal(8), np.zeros((0, 12)), np.zeros(0)
            )
        ],
    )
    x = solve_nullspace(problem).x
    assert np.allclose(x, solve_cascade(problem).x, atol=1e-8)
    problem.formulation = "full"
    with pytest.raises(ValueError, match="needs the model terms"):
        solve_nullspace(problem)


def test_activated_row_is_released_when_the_optimum_keeps_it_inside() -> None:
    """§3.2's grow-only activation pins z1 + z2 ≤ 1 too (violated by the unconstrained (3, −1))
    and answers (1, 0); with z1 ≤ 1 alone pinned the objective's optimum (1, −1) keeps
    z1 + z2 = 0 inside, so the row is released and the lower level is met exactly."""
    C = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    limits = Level(np.zeros((0, 2)), np.zeros(0), C, np.ones(3))
    objective = Level(np.eye(2), np.array([3.0, -1.0]), np.zeros((0, 2)), np.zeros(0))
    z = hierarchical_least_squares([limits, objective], 2)
    assert np.allclose(z, [1.0, -1.0], atol=1e-12)


def test_opposite_bounds_are_never_pinned_together() -> None:
    """−1 ≤ z1 ≤ 1 under z1 = 3 − 5 z2 then z2 = −1: the activated upper bound, then the lower one
    violated by the level below, end with one bound held and the level below met where it can."""
    C = np.array([[1.0, 0.0], [-1.0, 0.0]])
    bounds = Level(np.zeros((0, 2)), np.zeros(0), C, np.ones(2))
    first = Level(np.array([[1.0, 5.0]]), np.array([3.0]), np.zeros((0, 2)), np.zeros(0))
    second = Level(np.array([[0.0, 1.0]]), np.array([-1.0]), np.zeros((0, 2)), np.zeros(0))
    z = hierarchical_least_squares([bounds, first, second], 2)
    assert -1.0 - 1e-12 <= z[0] <= 1.0 + 1e-12
    assert abs(z[0] + 5 * z[1] - 3.0) <= 1e-12


def test_knee_and_hip_limits_converge_to_the_lexicographic_optimum(anymal) -> None:
    """Knees and hips limited to 10 N m under the motion (reduced [q̈, τ]): activating every
    violated row and releasing one at a time used to cycle between active sets here and stop at
    the iteration cap 3 kN m past a limit; stepping from the feasible point to the optimum of the
    new active set (blocked by the first row it would violate) holds every limit and tracks the
    motion as well as the cascade's lexicographic optimum."""
    stack = [["contact"], ["torque_limits"], ["com", "base_orientation"], ["posture", "torques"]]
    limits = np.full(12, 80.0)
    limits[[1, 2, 4, 5, 7, 8, 10, 11]] = 10.0
    c = controller(anymal, stack, (True,) * 4, seed=5, torque_limits=limits)
    problem = c.build_problem()
    problem.formulation = "qdd_tau"
    x = solve_nullspace(problem).x
    motion = problem.levels[2]
    assert np.all(np.abs(c.robot.joint_torques(x)) <= limits + AGREE_TOL)
    lexicographic = np.linalg.norm(motion.A @ solve_cascade(problem).x - motion.b)
    assert np.linalg.norm(motion.A @ x - motion.b) <= lexicographic + CASCADE_QP_TOL


def test_the_active_set_cap_stops_at_a_feasible_point_and_says_so(monkeypatch) -> None:
    """The release example above, started from z1 ≤ 1 and z1 + z2 ≤ 1 pinned, needs two
    hierarchy solves (one, and the trial that releases z1 + z2 ≤ 1; z1 ≤ 1's release is
    predicted to violate it, no solve); capped at one the search stops at the start's point,
    which holds every bound, and reports the cap; uncapped it reaches the optimum."""
    C = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    limits = Level(np.zeros((0, 2)), np.zeros(0), C, np.ones(3))
    objective = Level(np.eye(2), np.array([3.0, -1.0]), np.zeros((0, 2)), np.zeros(0))
    start = [np.array([True, False, True]), np.zeros(0, dtype=bool)]
    full = active_set_least_squares([limits, objective], 2, start=start)
    assert not full.capped and np.allclose(full.z, [1.0, -1.0], atol=1e-12)
    assert full.projections == 2
    capped = active_set_least_squares([limits, objective], 2, cap=1, start=start)
    assert capped.capped and capped.feasible
    assert np.all(C @ capped.z <= 1.0 + 1e-12)
    assert capped.projections <= full.projections - 1
    still_activating = active_set_least_squares([limits, objective], 2, cap=1)
    assert still_activating.capped and not still_activating.feasible
    monkeypatch.setattr(nullspace, "MAX_PROJECTIONS", 1)
    with pytest.warns(ActiveSetCapWarning, match="cap of 1 hierarchy solves"):
        hierarchical_least_squares([limits, objective], 2)


def stance_unloading() -> tuple[HierarchyProblem, Reparametrization, list[Level]]:
    """Talos at 1.30 s of `stance left` under Herzog's Table 4 stack (saved from a run): the
    problem, its change to the [q̈, F] search's variables and that search's levels."""
    data = np.load(Path(__file__).parent.parent / "data" / "talos_stance_unloading_problem.npz")
    count = sum(name.startswith("level") and name.endswith("_A") for name in data.files)
    levels = [Level(*(data[f"level{i}_{k}"] for k in "AbCd")) for i in range(count)]
    terms = DynamicsTerms(data["M"], data["h"], data["Jc"], data["support"])
    problem = HierarchyProblem(data["dynamics_A"], data["dynamics_b"], levels, terms)
    change = reparametrize(problem, problem.formulation)
    search_levels = [change.eom] + [change.level(level) for level in levels]
    return problem, change, search_levels


def test_a_contact_unloaded_to_zero_force_does_not_cycle_the_active_set() -> None:
    """Talos under Herzog's Table 4 stack, `stance left`, at 1.30 s (saved from a run): the right
    sole's normal-force bound is ramping to zero, so its normal, CoP and friction rows bind
    together near zero force, linearly dependent. Activating every violated row at once pinned 32
    rows (13 torque limits the optimum leaves free) and the search then cycled between releasing a
    row and re-activating it on a step of ~1e-12 (5000 solves at a cap of 5000); with the release
    tolerance for blocking it ended after 757. Activating the most violated row at a time it ends
    in 22 (bound here 40, the shipped cap 128) at the lexicographic optimum: the cascade's level
    residuals on the same tick."""
    problem, change, levels = stance_unloading()
    search = active_set_least_squares(levels, change.T.shape[1], cap=40)
    assert not search.capped and search.feasible
    x, x_cascade = change.T @ search.z + change.t, solve_cascade(problem).x
    assert np.max(np.abs(problem.dynamics_A @ x - problem.dynamics_b)) <= 1e-6
    for level in problem.levels:
        assert np.all(level.C @ x - level.d <= AGREE_TOL)
        residual = np.linalg.norm(level.A @ x - level.b)
        assert residual == pytest.approx(np.linalg.norm(level.A @ x_cascade - level.b), rel=1e-4)


def test_a_search_started_from_its_optimal_active_rows_ends_there_at_once() -> None:
    """As the controller starts each tick from the last tick's active rows: started from where
    the cold search of the tick above stopped (4 rows), the same z in 1 + 4 solves (the solve,
    then a release trial per row that stays active), not 22."""
    _, change, levels = stance_unloading()
    cold = active_set_least_squares(levels, change.T.shape[1])
    warm = active_set_least_squares(levels, change.T.shape[1], start=cold.active)
    active_rows = sum(int(on.sum()) for on in cold.active)
    assert not warm.capped and warm.projections <= 1 + active_rows < cold.projections
    np.testing.assert_allclose(warm.z, cold.z, atol=1e-9)
    assert [list(on) for on in warm.active] == [list(on) for on in cold.active]


def test_a_search_walked_from_a_point_ends_at_the_same_optimum() -> None:
    """As the controller starts each tick from the last tick's x too: where the solution of the
    start rows (here none) violates a row, the search pins the rows the point violates and walks
    from the point to the optimum. From the optimum itself it ends there in fewer solves than the
    cold search (which activates a row per solve first); from a point far off (every force and
    acceleration off by up to 100), at the same optimum."""
    _, change, levels = stance_unloading()
    n = change.T.shape[1]
    cold = active_set_least_squares(levels, n)
    near = active_set_least_squares(levels, n, point=cold.z)
    assert not near.capped and near.projections < cold.projections
    np.testing.assert_allclose(near.z, cold.z, atol=1e-9)
    far_point = cold.z + np.random.default_rng(0).uniform(-100.0, 100.0, n)
    far = active_set_least_squares(levels, n, cap=1000, point=far_point)
    assert not far.capped and far.feasible
    np.testing.assert_allclose(far.z, cold.z, atol=1e-6)


def test_the_last_ticks_start_is_dropped_with_the_stack_or_method_it_belongs_to(
    anymal, monkeypatch
) -> None:
    """The controller starts each nullspace tick from the last tick's active rows and x; a new
    stack, method or formulation starts cold (those were another problem's), a new solver for
    the other methods does not."""
    starts: list[tuple] = []

    def spy(problem: HierarchyProblem, solver: str):
        starts.append((len(problem.active_start), problem.x_start is not None))
        return solve_nullspace(problem, solver)

    monkeypatch.setitem(METHODS, "nullspace", spy)
    c = controller(anymal, STRICT, (True, True, True, True), seed=0)
    c.set_hierarchy("nullspace")
    cold, warm = (0, False), (1, True)  # qdd_force: one search, its active rows and x
    c.solve()
    c.solve()
    assert starts == [cold, warm]
    c.set_stack(Stack.of([["contact"], ["com", "base_orientation"], ["posture"]]))
    c.solve()
    c.set_hierarchy("nullspace", solver="clarabel")  # the same problem: the start holds
    c.solve()
    c.set_hierarchy("nullspace", formulation="sequential")
    c.solve()
    c.set_hierarchy("cascade")
    c.solve()  # not the spy: the cascade's x is stored as the last tick's
    c.set_hierarchy("nullspace", formulation="qdd_force")
    c.solve()
    assert starts[2:] == [cold, warm, cold, cold]


def test_release_trials_decided_from_the_main_solve_decide_as_the_trials_on_g1_unloading(
    monkeypatch,
) -> None:
    """G1's searches while its leaving sole unloads (tests/helpers/unload.py), every release trial
    run and compared with `_predicted_violation`: where the prediction is clear-cut it is the
    trial's violation (relative 1e-5; measured 4e-7), so every trial it skips (predicted above
    ACTIVATION_TOL by RELEASE_MARGIN) keeps its row and every predicted release releases it; and
    it is clear-cut on most trials (measured: all)."""
    records, pending = [], []
    predict, project = nullspace._predicted_violation, nullspace._project

    def predicted(levels, active, entry, k, j):  # recorded, and the trial left to run
        pending[:] = [(levels[k], j, predict(levels, active, entry, k, j))]
        return None

    def projected(levels, active, n, entry, first, budget):  # after a prediction: its trial
        z = project(levels, active, n, entry, first, budget)
        if pending:
            level, j, guess = pending.pop()
            margin = nullspace.RELEASE_MARGIN * max(1.0, abs(level.d[j]))
            violation = float(level.C[j] @ z - level.d[j])
            records.append((np.nan if guess is None else guess, violation, margin))
        return z

    monkeypatch.setattr(nullspace, "_predicted_violation", predicted)
    monkeypatch.setattr(nullspace, "_project", projected)
    for levels, n, start, point in g1_unload_searches(UNLOAD_TICKS):
        active_set_least_squares(levels, n, start=start, point=point)
    guess, violation, margin = np.array(records).T
    clear = ~np.isnan(guess)
    assert len(records) >= 100 and np.count_nonzero(clear) >= 0.9 * len(records)
    np.testing.assert_allclose(guess[clear], violation[clear], rtol=1e-5, atol=1e-9)
    tol = nullspace.ACTIVATION_TOL
    assert np.all(violation[clear & (guess - tol > margin)] > tol)
    assert np.all(violation[clear & (tol - guess > margin)] <= tol)
