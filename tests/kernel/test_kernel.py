"""The native kernel (lab._kernel) against the Python controller, its oracle.

Same model (pinocchio's serialization), same rows for every task and constraint on random states
and references of every robot, the same hierarchy problem for every stack preset, and clear
errors for bad input. Skipped as a whole when the kernel is not built.
"""

import copy
import dataclasses
import functools
import json

import numpy as np
import pinocchio as pin
import pytest

from lab.controller import native
from lab.controller.behaviours import leg_posture
from lab.controller.behaviours.balance import standing_references
from lab.controller.behaviours.leg_posture import LegPostureReference
from lab.controller.controller import ControllerConfig, WholeBodyController
from lab.controller.model import RobotModel
from lab.controller.native import (
    NOT_BUILT,
    NativeController,
    native_available,
    send_references,
)
from lab.controller.references import References, SoleReferences, WalkReferences
from lab.controller.stack import Stack
from lab.description import ROBOT_NAMES, load_description
from lab.experiments.scenario import load_scenario, run_scenario
from lab.robot import build_robot
from lab.stack_presets import PRESET_NAMES, load_stack_preset
from lab.world.session import Session, SessionConfig
from tests.helpers.controllers import controller_for
from tests.helpers.kernel import (
    ROWS_TOL,
    WEIGHTED_COST_TOL,
    _kernel,
    assert_rows_equal,
    kernel_of,
    momentum_gain,
    random_state,
    send_internal_force,
    send_python_feedback,
)

STATES = 6  # random states per robot


def random_sensing(controller: WholeBodyController, rng: np.random.Generator) -> None:
    """A random internal-force reference and source, and random sensed foot forces and torques
    (Kim eqs. 12–13), on the Python controller."""
    task, model = controller.internal_force, controller.robot
    task.reference = float(rng.normal(0.0, 5.0))
    task.set_source(str(rng.choice(["contacts", "torques"])))
    forces = rng.normal(0.0, 3.0, (len(model.contacts), 3))
    forces[:, 2] += model.mass * 9.81 / 2
    controller.set_sensing(forces, rng.normal(0.0, 2.0, model.na))


@dataclasses.dataclass
class AllReferences(WalkReferences, SoleReferences):
    """Every field of the references' dataclasses at once, for random draws."""


REFERENCE_CLASSES = (References, WalkReferences, SoleReferences)


def _rotations(rng: np.random.Generator, count: int) -> np.ndarray:
    return np.array([pin.rpy.rpyToMatrix(*rng.uniform(-0.3, 0.3, 3)) for _ in range(count)])


def _weights(rng: np.random.Generator, n: int, nan: float, zero: float) -> np.ndarray:
    w = rng.uniform(0.0, 1.0, n)
    w[rng.random(n) < nan] = np.nan
    w[rng.random(n) < zero] = 0.0
    return w


def _active(rng: np.random.Generator, n: int) -> np.ndarray:
    active = rng.random(n) < 0.5
    active[rng.integers(n)] = True
    return active


UP = np.array([0.0, 0.0, 1.0])


def _unit(vectors: np.ndarray) -> np.ndarray:
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


# Fields whose values need a structure (rotations, unit normals, weights, positions near the
# robot's); every other field is drawn by its type and shape alone.
VALUE_RULES = {
    "com": lambda m, rng: m.com + rng.normal(0.0, 0.05, 3),
    "posture": lambda m, rng: m.q[7:] + rng.normal(0.0, 0.1, m.na),
    "base_height": lambda m, rng: float(m.q[2] + rng.normal(0.0, 0.05)),
    "base_rotation": lambda m, rng: _rotations(rng, 1)[0],
    "contact_active": lambda m, rng: _active(rng, len(m.contacts)),
    "normal_force_max": lambda m, rng: rng.uniform(100.0, 900.0, len(m.contacts)),
    "foot_position": lambda m, rng: (
        m.contact_positions + rng.normal(0.0, 0.05, (len(m.contacts), 3))
    ),
    "surface_normal": lambda m, rng: _unit(rng.normal(0.0, 0.3, (len(m.contacts), 3)) + UP),
    "force_weight": lambda m, rng: _weights(rng, len(m.contacts), nan=0.4, zero=0.0),
    "posture_weight": lambda m, rng: _weights(rng, len(m.contacts), nan=0.0, zero=0.3),
    "sole_position": lambda m, rng: (
        m.contact_positions + rng.normal(0.0, 0.05, (len(m.contacts), 3))
    ),
    "sole_rotation": lambda m, rng: _rotations(rng, len(m.contacts)),
    "leg_position": lambda m, rng: m.q[7:] + rng.normal(0.0, 0.1, m.na),
}


def random_references(model: RobotModel, rng: np.random.Generator, walk: bool) -> AllReferences:
    """References with a random value in every field of the references' dataclasses, drawn by the
    layout the kernel reads (`_kernel.reference_fields()`: type and shape) and VALUE_RULES;
    `walk=False` leaves the fields References does not declare at their (empty) defaults."""
    layout = {name: (kind, shape) for name, _, kind, shape in _kernel.reference_fields()}
    sizes = {
        "n": len(model.contacts),
        "na": model.na,
        "h": 0,
    }  # hands: tests/controller/test_hands.py
    plain = {f.name for f in dataclasses.fields(References)}
    values = {}
    for f in dataclasses.fields(AllReferences):
        kind, shape = layout[f.name]  # a KeyError: a field the kernel does not read
        if not walk and f.name not in plain:
            continue
        if f.name in VALUE_RULES:
            values[f.name] = VALUE_RULES[f.name](model, rng)
            continue
        dims = tuple(sizes[d] if d in sizes else int(d) for d in shape.split(",") if d)
        if kind == "bool":
            values[f.name] = rng.random(dims) < 0.5
        else:
            values[f.name] = rng.normal(0.0, 0.3, dims)
    return AllReferences(**values)


def test_the_references_have_one_layout_on_both_sides() -> None:
    """The kernel reads exactly the fields of References, WalkReferences and SoleReferences, each
    declared by the same class, in declaration order, with the type and number of dimensions of
    the dataclass's own default (a field on one side only fails here)."""
    kernel_fields = _kernel.reference_fields()
    python = []
    for cls in REFERENCE_CLASSES:
        for f in dataclasses.fields(cls):
            if cls is References or f.name not in {g.name for g in dataclasses.fields(References)}:
                python.append((f, cls.__name__))
    assert [name for name, *_ in kernel_fields] == [f.name for f, _ in python]
    for (name, declared_by, kind, shape), (f, cls_name) in zip(kernel_fields, python, strict=True):
        assert declared_by == cls_name, name
        dims = [d for d in shape.split(",") if d]
        if f.type is float or f.type == "float":
            assert kind == "float" and not dims, name
            continue
        if f.default_factory is dataclasses.MISSING:  # required arrays: com, posture
            assert kind == "float64", name
            continue
        default = np.asarray(f.default_factory())
        assert kind == {"float64": "float64", "bool": "bool"}[default.dtype.name], name
        assert len(dims) == max(default.ndim, 1), name
    assert set(VALUE_RULES) <= {name for name, *_ in kernel_fields}


def random_gains(controller: WholeBodyController, kernel, rng: np.random.Generator) -> None:
    """Nonzero gains on every task (the robots' own leave most of them zero), both sides."""
    for name in controller.tasks:
        kp, kd = rng.uniform(1.0, 400.0, 2)
        weight = 1.0 if rng.random() < 0.5 else float(rng.uniform(1e-3, 10.0))
        controller.set_gains(name, kp, kd, weight)
        kernel.set_gains(name, kp, kd, weight)


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_the_kernel_loads_the_same_model(name: str) -> None:
    controller, robot = controller_for(name)
    kernel = kernel_of(controller)
    model = robot.model
    assert (kernel.nq, kernel.nv) == (model.nq, model.nv)
    assert kernel.nf == controller.robot.nf and kernel.nx == controller.robot.nx
    assert kernel.frame_names() == [frame.name for frame in model.frames]
    inertias = np.array([inertia.toDynamicParameters() for inertia in model.inertias])
    np.testing.assert_allclose(kernel.inertias(), inertias, rtol=1e-12, atol=1e-12)
    assert kernel.mass == pytest.approx(controller.robot.mass, rel=1e-12)


@pytest.mark.parametrize("name", ["anymal", "talos"])
def test_the_kernels_model_update_fills_the_python_models_arrays(name: str) -> None:
    """One pinocchio pass serves both sides: what the kernel writes into the Python model's arrays
    is what RobotModel.update computes at the same state, frame placements included."""
    controller, robot = controller_for(name)
    kernel = kernel_of(controller)
    mirrored = controller.robot
    kernel.mirror_model(mirrored.arrays())
    reference = RobotModel(robot.model, robot.contacts)
    rng = np.random.default_rng(7)
    for _ in range(STATES):
        q, v = random_state(robot, rng)
        kernel.update(q, v)
        mirrored.filled_elsewhere()
        reference.update(q, v)
        for field, array in reference.arrays().items():
            scale = 1.0 + np.abs(array).max()
            np.testing.assert_allclose(
                getattr(mirrored, field), array, rtol=0, atol=ROWS_TOL * scale, err_msg=field
            )
        np.testing.assert_allclose(
            mirrored.centroidal_momentum(), reference.data.hg.vector, atol=1e-9
        )
        base = robot.base_link
        np.testing.assert_allclose(
            mirrored.frame_position(base), reference.frame_position(base), atol=1e-12
        )
    with pytest.raises(ValueError, match="'Jc' has the wrong shape"):
        kernel.mirror_model({**mirrored.arrays(), "Jc": np.zeros((2, 2))})


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_rows_of_every_task_and_constraint_agree(name: str) -> None:
    controller, robot = controller_for(name)
    kernel = kernel_of(controller)
    model = controller.robot
    assert sorted(kernel.known_names()) == sorted(controller.known_names)
    # The PD law: an LQR design needs contacts that can hold the momentum (one point foot
    # cannot); test_kernel_herzog.py has the LQR laws on Talos.
    controller.set_momentum_mode("pd")
    rng = np.random.default_rng(12)
    for i in range(STATES):
        q, v = random_state(robot, rng)
        model.update(q, v)
        kernel.update(q, v)
        refs = random_references(model, rng, walk=i % 2 == 0)
        send_references(kernel, refs)
        random_gains(controller, kernel, rng)
        if i:  # the first state before any sensed step: the command is the reference
            random_sensing(controller, rng)
        send_internal_force(controller, kernel)
        for task_name, task in controller.tasks.items():
            python = task.rows(model, refs)  # A, b, error
            if task_name == "momentum":
                kernel.set_momentum_gain(momentum_gain(controller))
            native = kernel.rows(task_name)
            assert_rows_equal(native, python[:2], f"{name} state {i}: task {task_name}")
        for constraint_name, constraint in controller.constraints.items():
            python = constraint.rows(model, refs)
            native = kernel.rows(constraint_name)
            assert_rows_equal(native, python, f"{name} state {i}: {constraint_name}")


def stacks_of(name: str, known: tuple[str, ...]) -> list[tuple[str, list[list[str]]]]:
    """The robot's default stack and every preset whose names are all `known` on the robot (the
    soles' constraints need flat feet)."""
    default = [list(level) for level in load_description(name).stack]
    stacks = [("default", default)] + [(p, load_stack_preset(p).levels) for p in PRESET_NAMES]
    return [(s, levels) for s, levels in stacks if set(Stack.of(levels).names()) <= set(known)]


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_the_hierarchy_problem_of_every_stack_agrees(name: str) -> None:
    controller, robot = controller_for(name)
    kernel = kernel_of(controller)
    model = controller.robot
    rng = np.random.default_rng(5)
    for stack_name, levels in stacks_of(name, controller.known_names):
        controller.set_stack(Stack.of(levels))
        kernel.set_stack(levels)
        for i in range(2):
            q, v = random_state(robot, rng)
            model.update(q, v)
            kernel.update(q, v)
            controller.references = random_references(model, rng, walk=i == 0)
            send_references(kernel, controller.references)
            random_gains(controller, kernel, rng)
            python = controller.build_problem()
            send_python_feedback(controller, kernel)
            native = kernel.problem()
            what = f"{name} {stack_name} state {i}"
            assert_rows_equal(
                (native["dynamics_A"], native["dynamics_b"]),
                (python.dynamics_A, python.dynamics_b),
                what,
            )
            assert len(native["levels"]) == len(python.levels)
            for k, (got, want) in enumerate(zip(native["levels"], python.levels, strict=True)):
                assert_rows_equal(got[:4], (want.A, want.b, want.C, want.d), f"{what} level {k}")
                assert got[4] == pytest.approx(want.weight, rel=1e-15)
            np.testing.assert_array_equal(native["support"], python.terms.support)


def test_bad_input_raises_a_clear_error_and_changes_nothing() -> None:
    controller, robot = controller_for("anymal")
    kernel = kernel_of(controller)
    q, v = robot.q_standing, np.zeros(robot.model.nv)
    with pytest.raises(ValueError, match="q has non-finite"):
        kernel.update(np.full_like(q, np.nan), v)
    with pytest.raises(ValueError, match="v has 3 entries"):
        kernel.update(q, np.zeros(3))
    with pytest.raises(KeyError, match="no task or constraint 'nope'"):
        kernel.set_stack([["contact"], ["nope"]])
    with pytest.raises(ValueError, match="level 2 is empty"):
        kernel.set_stack([["contact"], []])
    with pytest.raises(KeyError, match="unknown task"):
        kernel.set_gains("nope", 1.0)
    with pytest.raises(KeyError, match="no hierarchy method 'newton'"):
        kernel.set_method("newton")
    refs = controller.references
    with pytest.raises(ValueError, match="posture has 3 entries"):
        send_references(kernel, WalkReferences(com=refs.com, posture=np.zeros(3), base_height=0.5))
    with pytest.raises(ValueError, match="not a serialized pinocchio model"):
        _kernel.Kernel("garbage", [], np.zeros(0), np.zeros(0), np.zeros(0), 0.8, 0.0, 1e3)
    # The kernel still works after every rejected call.
    kernel.update(q, v)
    send_references(kernel, refs)
    A, b = kernel.rows("posture")
    assert A.shape == (robot.model.nv - 6, kernel.nx) and np.all(np.isfinite(b))


def test_tick_into_reads_the_references_object_changed_in_place_or_replaced() -> None:
    """NativeController's one crossing per tick: the kernel reads the References object itself,
    sees an array the behaviour changed in place or replaced, and writes the τ and x the tuple
    API returns for the same references (with the model update in the same call or before it);
    bad references raise and change nothing, not even the model's state."""
    controller, robot = controller_for("anymal")
    model = controller.robot
    kernel = kernel_of(controller)
    kernel.set_stack(controller.config.stack.as_lists())
    rng = np.random.default_rng(8)
    q, v = random_state(robot, rng)
    model.update(q, v)
    kernel.update(q, v)
    tau, x = np.zeros(model.na), np.zeros(model.nx)
    plain = copy.deepcopy(controller.references)
    walking = random_references(model, rng, walk=True)
    walking.contact_active[:] = True
    for refs in (plain, walking, plain):
        for change in ("as given", "in place", "replaced"):
            if change == "in place":
                refs.com += 0.02
                refs.posture[0] += 0.1
            elif change == "replaced":
                refs.com = refs.com - 0.03
                refs.base_height += 0.01
            state = (q, v) if change == "in place" else (None, None)  # the update in the call
            outcome = kernel.tick_into(refs, tau, x, *state)
            send_references(kernel, refs)
            want_tau, want_qdd, want_forces, want_ok, *_ = kernel.solve()
            what = f"{type(refs).__name__} {change}"
            assert outcome.ok and want_ok, f"{what}: {outcome.message}"
            np.testing.assert_array_equal(tau, want_tau, err_msg=what)
            np.testing.assert_array_equal(x, np.r_[want_qdd, want_forces], err_msg=what)
            levels, residuals = outcome.levels, outcome.residuals
            assert isinstance(levels, tuple) and len(levels) == len(residuals), what
            assert outcome.fallback_levels == (), what
            assert set(outcome.task_errors) <= set(controller.config.stack.names()), what
    assert kernel.tick_into(walking, tau, x).ok
    before = tau.copy()
    bad = copy.deepcopy(walking)
    bad.posture = np.zeros(3)
    with pytest.raises(ValueError, match="posture has 3 entries"):
        kernel.tick_into(bad, tau, x, *random_state(robot, rng))
    np.testing.assert_array_equal(tau, before)
    with pytest.raises(ValueError, match="both q and v"):
        kernel.tick_into(walking, tau, x, q)
    assert kernel.tick_into(walking, tau, x).ok
    np.testing.assert_array_equal(tau, before)  # the state is still (q, v)


def test_a_method_the_kernel_lacks_runs_on_python_and_says_so_in_its_note(monkeypatch) -> None:
    monkeypatch.setattr(native, "NATIVE_METHODS", ("cascade", "weighted"))  # as before nullspace's
    description = load_description("anymal")
    robot = build_robot(description)
    model = RobotModel(robot.model, robot.contacts)
    config = ControllerConfig(Stack.of(description.stack), dict(description.gains))
    controller = NativeController(
        model, standing_references(model, robot.q_standing), config, robot.torque_limits
    )
    controller.set_hierarchy("nullspace")
    controller.compute(robot.q_standing, np.zeros(robot.model.nv))
    assert controller.kernel_ran == "python"
    assert "nullspace" in controller.kernel_note or NOT_BUILT


@pytest.mark.parametrize("why", ["python asked", "nullspace", "not built", "stack"])
def test_the_python_kernel_runs_exactly_when_native_is_not_asked_or_the_note_says_why(
    why, monkeypatch
) -> None:
    """One rule picks the kernel of a tick: native when asked and `kernel_note` is empty."""
    description = load_description("anymal")
    robot = build_robot(description)
    model = RobotModel(robot.model, robot.contacts)
    config = ControllerConfig(Stack.of(description.stack), dict(description.gains))
    refs = standing_references(model, robot.q_standing)
    controller = NativeController(model, refs, config, robot.torque_limits)
    v = np.zeros(robot.model.nv)
    controller.compute(robot.q_standing, v)
    assert (controller.kernel_ran, controller.kernel_note) == ("native", "")
    if why == "python asked":
        controller.set_kernel("python")
    elif why == "nullspace":  # a method the kernel would lack (every method but wbosc is native)
        monkeypatch.setattr(native, "NATIVE_METHODS", ("cascade", "weighted"))
        controller.set_hierarchy("nullspace")
    elif why == "not built":
        monkeypatch.setattr(native, "NOT_BUILT", "the native kernel is not built (test)")
    else:  # every task is native today: the note a task written in Python only would leave
        controller._unsupported = "the native kernel has no task 'python_only'"
    controller.compute(robot.q_standing, v)
    assert controller.kernel_ran == "python"
    assert bool(controller.kernel_note) == (why != "python asked"), controller.kernel_note


def test_compute_in_one_crossing_equals_update_then_solve_and_each_output_keeps_its_tick() -> None:
    """NativeController.compute (model update and solve in one crossing) gives the τ and x of
    update() then solve(), fills the Python model as update() does, and each output's solution
    and task errors (built when first read) stay those of its own tick after later ticks."""
    description = load_description("anymal")
    robot = build_robot(description)
    outputs, models = [], []
    for fused in (True, False):
        model = RobotModel(robot.model, robot.contacts)
        config = ControllerConfig(Stack.of(description.stack), dict(description.gains))
        controller = NativeController(
            model, standing_references(model, robot.q_standing), config, robot.torque_limits
        )
        rng = np.random.default_rng(3)
        ticks = []
        for _ in range(3):
            q, v = random_state(robot, rng)
            if fused:
                ticks.append(controller.compute(q, v))
            else:
                controller.update(q, v)
                ticks.append(controller.solve())
            assert controller.kernel_ran == "native"
        outputs.append(ticks)
        models.append(model)
    for fused, unfused in zip(*outputs, strict=True):
        np.testing.assert_array_equal(fused.tau, unfused.tau)
        np.testing.assert_array_equal(fused.solution.x, np.r_[unfused.qdd, unfused.forces])
        assert fused.solution.residuals == unfused.solution.residuals
        assert fused.task_errors == unfused.task_errors and fused.task_errors
        assert fused.fallback_levels == () and fused.torques_finite()
    for name in ("q", "M", "h", "Jc", "com", "contact_positions"):
        np.testing.assert_array_equal(getattr(models[0], name), getattr(models[1], name))
    assert models[0].updated_by == "native"
    first, last = outputs[0][0], outputs[0][-1]
    assert first.solution.residuals != last.solution.residuals  # read after two more ticks


def test_a_session_runs_native_by_default_and_switches_live() -> None:
    session = Session(SessionConfig(robot="anymal"))
    for _ in range(20):
        session.tick()
    telemetry = session.telemetry()
    assert (telemetry["kernel"], telemetry["kernel_note"]) == ("native", "")
    assert session.qp_ok
    before = json.dumps(session.info(), sort_keys=True)
    reply = session.handle("hierarchy", {"kernel": "fast"})
    assert not reply["ok"] and "unknown kernel 'fast'" in reply["error"]
    assert json.dumps(session.info(), sort_keys=True) == before
    assert session.handle("hierarchy", {"kernel": "python"})["ok"]
    session.tick()
    assert session.telemetry()["kernel"] == "python"
    assert session.info()["kernel"] == "python"
    assert session.handle("hierarchy", {"method": "weighted", "kernel": "native"})["ok"]
    session.tick()
    assert session.telemetry()["kernel"] == "native"
    assert session.controller.config.method == "weighted"


def test_a_method_the_kernel_lacks_runs_on_python_and_says_so(monkeypatch) -> None:
    monkeypatch.setattr(native, "NATIVE_METHODS", ("cascade", "weighted"))  # as before nullspace's
    session = Session(SessionConfig(robot="anymal"))
    assert session.handle("hierarchy", {"method": "nullspace"})["ok"]
    session.tick()
    telemetry = session.telemetry()
    assert telemetry["kernel"] == "python"
    assert "no method 'nullspace'" in telemetry["kernel_note"]


def test_a_native_solver_failure_falls_back_and_is_reported() -> None:
    session = Session(SessionConfig(robot="anymal", method="weighted"))
    # A normal force at least 200 N and at most 100 N: the weighted QP (hard limits) is infeasible.
    limits = session.controller.config.limits
    limits.normal_min, limits.normal_max = 200.0, 100.0
    for _ in range(5):
        session.tick()
    assert session.telemetry()["kernel"] == "native"
    assert session.qp_failures == 5 and not session.qp_ok
    events = [e for e in session.pop_events() if e["type"] == "solver_failure"]
    assert events and "native weighted" in events[0]["message"]


def native_weighted(problem) -> dict:
    """The native weighted method on a Python HierarchyProblem."""
    levels = [(lv.A, lv.b, lv.C, lv.d, lv.weight) for lv in problem.levels]
    support = np.ones(problem.dynamics_A.shape[1] - problem.dynamics_A.shape[0], dtype=bool)
    return _kernel.solve_hierarchy(
        "weighted", problem.dynamics_A, problem.dynamics_b, levels, support
    )


def test_the_weighted_qp_eiquadprog_cycled_on_ends_bounded_and_says_infeasible() -> None:
    """ANYmal standing with a normal force of at least 200 N and at most 100 N: eiquadprog 1.3.2
    cycled without end on this weighted QP (setMaxIter did not stop it). DAQP returns within its
    iteration limit and names the cause; the same limits made sane again give a solution."""
    controller, robot = controller_for("anymal", method="weighted")
    controller.robot.update(robot.q_standing, np.zeros(robot.model.nv))
    limits = controller.config.limits
    sane = (limits.normal_min, limits.normal_max)
    limits.normal_min, limits.normal_max = 200.0, 100.0
    failed = native_weighted(controller.build_problem())
    assert not failed["ok"] and "infeasible" in failed["message"], failed["message"]
    iterations = int(failed["message"].split(", ")[-1].split()[0])
    assert iterations <= _kernel.qp_iteration_limit, failed["message"]
    limits.normal_min, limits.normal_max = sane
    solved = native_weighted(controller.build_problem())
    assert solved["ok"], solved["message"]
    forces = solved["x"][robot.model.nv :].reshape(-1, 3)
    assert forces[:, 2].sum() == pytest.approx(controller.robot.mass * 9.81, rel=0.05)


def test_degenerate_qps_end_in_bounded_iterations_with_a_status() -> None:
    """Two stated degenerate QPs through the kernel's backend: rows that contradict each other
    with two nonzeros each (no single-entry bound a precheck could catch), and a feasible QP whose
    optimum sits on 40 copies of the same row (a degenerate vertex, where active-set methods can
    cycle). Each returns within the iteration limit with its status."""
    n = 6
    P, q = np.eye(n), -np.ones(n)
    no_rows, no_rhs = np.zeros((0, n)), np.zeros(0)
    row = np.zeros(n)
    row[:2] = 1.0  # x0 + x1 <= -1 and x0 + x1 >= 1
    G, h = np.vstack([row, -row]), np.array([-1.0, -1.0])
    x, ok, flag, name, iterations = _kernel.solve_qp(P, q, G, h, no_rows, no_rhs)
    assert not ok and flag < 0 and name == "infeasible"
    assert iterations <= _kernel.qp_iteration_limit
    # min ½|x - 1|² with sum(x) <= 1, forty times over, and x0 = x1 (as an equality row)
    G, h = np.tile(np.ones(n), (40, 1)), np.ones(40)
    A, b = np.array([[1.0, -1.0, 0.0, 0.0, 0.0, 0.0]]), np.zeros(1)
    x, ok, flag, name, iterations = _kernel.solve_qp(P, q, G, h, A, b)
    assert ok and name == "optimal" and iterations <= _kernel.qp_iteration_limit
    # the projection of 1 onto sum(x) = 1 (it also has x0 = x1)
    np.testing.assert_allclose(x, np.full(n, 1.0 / n), atol=1e-9)


@pytest.mark.parametrize("name", ["anymal", "hyq", "solo12"])
def test_the_native_leg_posture_update_agrees_with_python(name: str) -> None:
    """LegPostureReference.update on a tick whose model update the native kernel ran
    (cpp/behaviours/leg_posture.cpp) against its Python steps: random states, stance sets, swing
    references and commanded twists, three ticks in a row (the stance feet roll from the last
    tick's orientations); q̇_d, q_d and the kept orientations equal to 1e-9."""
    assert leg_posture.native_velocity is not None, "the kernel lacks leg_posture_velocity"
    rng = np.random.default_rng(12)
    controller, robot = controller_for(name)
    model = controller.robot
    python = LegPostureReference(model, robot.q_standing[7:])
    native = LegPostureReference(model, robot.q_standing[7:])
    n = len(model.contacts)
    for _ in range(3):
        model.update(*random_state(robot, rng))
        stance = rng.random(n) < 0.5
        swing = (
            model.contact_positions + rng.normal(0.0, 0.05, (n, 3)),
            rng.normal(0.0, 0.3, (n, 3)),
        )
        twist = (rng.normal(0.0, 0.3, 3), rng.normal(0.0, 0.5, 3))
        tick = (0.001, stance, *swing, *twist, float(rng.normal(0.0, 0.02)))
        python.update(model, *tick)
        model.filled_elsewhere()  # as after the kernel's update: the native steps run
        native.update(model, *tick)
        scale = 1.0 + np.abs(python.velocity).max()
        np.testing.assert_allclose(native.velocity, python.velocity, rtol=0, atol=1e-9 * scale)
        np.testing.assert_allclose(native.position, python.position, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(native._rotations, python._rotations)


QUADRUPEDS = ("anymal", "hyq", "solo12")
X_TOL = 1e-6  # relative to 1 + |x|: DAQP's primal tolerance, with room for the float order
TAU_TOL = 1e-6  # N m, where every level of the cascade was solved without a QP
LEVEL_TOL = 1e-7  # relative: two residuals of a level are equal
# Below this lightest level weight the weighted Hessian spans more than 1e9: DAQP then stops
# short of the optimum (hutter_table7's 7 levels reach 1e-18), so x is compared through the cost.
WELL_CONDITIONED_WEIGHT = 1e-9


@functools.cache
def recorded_states(name: str) -> tuple:
    """(tag, q, v, references) from a Python-kernel session: standing, pushed, trotting."""
    session = Session(SessionConfig(robot=name, kernel="python"))
    states = []

    def run(ticks: int, tag: str) -> None:
        for _ in range(ticks):
            session.tick()
        model = session.model
        refs = copy.deepcopy(session.controller.references)
        states.append((tag, model.q.copy(), model.v.copy(), refs))

    run(100, "standing")
    push = [0.0, 0.15 * session.model.mass * 9.81, 0.0]
    session.handle("push", {"body": session.robot.base_link, "force": push, "duration": 0.1})
    run(60, "push")
    if name in QUADRUPEDS:
        session.handle("gait", {"name": "trot"})
        session.handle("velocity", {"vx": 0.3, "vy": 0.0, "yaw_rate": 0.0})
        run(150, "trot")
        run(80, "trot later")
    assert not session.fell
    return tuple(states)


def level_residual(level, x: np.ndarray) -> float:
    """‖A x − b‖ and the violation of C x ≤ d together: what a strict level minimises."""
    violation = np.maximum(level.C @ x - level.d, 0.0)
    return float(np.sqrt(np.sum((level.A @ x - level.b) ** 2) + violation @ violation))


def lexicographically_no_worse(problem, x: np.ndarray, reference: np.ndarray) -> bool:
    """Level by level, x's residual equals the reference's within LEVEL_TOL until the first level
    where they differ, and there x's is the smaller."""
    for level in problem.levels:
        r, r_ref = level_residual(level, x), level_residual(level, reference)
        if abs(r - r_ref) > LEVEL_TOL * (1.0 + r_ref):
            return r < r_ref
    return True


def weighted_cost(problem, x: np.ndarray) -> float:
    """The weighted method's objective (hierarchy/weighted.py)."""
    lightest = min(level.weight for level in problem.levels)
    cost = sum(level.weight * np.sum((level.A @ x - level.b) ** 2) for level in problem.levels)
    return float(cost + 1e-9 * lightest * x @ x)


@pytest.mark.skipif(not native_available(), reason=NOT_BUILT or "native kernel built")
@pytest.mark.parametrize("name", ROBOT_NAMES)
@pytest.mark.parametrize("method", ["cascade", "weighted"])
def test_the_whole_tick_agrees_with_python(name: str, method: str) -> None:
    states = recorded_states(name)
    known = controller_for(name)[0].known_names
    for stack_name, levels in stacks_of(name, known):
        controller, _ = controller_for(name)
        kernel = kernel_of(controller)
        controller.set_stack(Stack.of(levels))
        kernel.set_stack(levels)
        controller.set_hierarchy(method)
        kernel.set_method(method)
        for tag, q, v, refs in states:
            what = f"{name} {stack_name} {method} {tag}"
            controller.references = refs
            controller.robot.update(q, v)
            send_references(kernel, refs)
            python = controller.solve()
            send_python_feedback(controller, kernel)
            tau, qdd, forces, ok, message, statuses, _, _, errors, seconds = kernel.tick(q, v)
            assert ok, f"{what}: {message}"
            assert len(seconds) == len(statuses) and all(s >= 0.0 for s in seconds), what
            assert 0.0 < sum(seconds) < 1.0, what  # each level timed, in seconds
            python_errors = controller.task_errors()
            assert errors.keys() == python_errors.keys(), what
            for task, error in errors.items():
                assert error == pytest.approx(python_errors[task], rel=ROWS_TOL, abs=ROWS_TOL)
            x, x_native = np.r_[python.qdd, python.forces], np.r_[qdd, forces]
            problem = controller.build_problem()
            lightest = min(level.weight for level in problem.levels)
            x_differs = np.abs(x_native - x).max() > X_TOL * (1.0 + np.abs(x).max())
            if method == "weighted" and (lightest < WELL_CONDITIONED_WEIGHT or x_differs):
                # Where the weighted optimum is flat (Solo12's default stack: cond(H) ~4e9, x
                # fixed to ~3e-5 only, the two costs equal to 1e-13), x is compared by its cost.
                for level in problem.levels:  # hard inequalities, and a cost no worse
                    assert np.all(level.C @ x_native <= level.d + X_TOL * (1 + abs(level.d))), what
                cost, cost_native = weighted_cost(problem, x), weighted_cost(problem, x_native)
                tolerance = X_TOL if lightest < WELL_CONDITIONED_WEIGHT else WEIGHTED_COST_TOL
                assert cost_native <= cost * (1 + tolerance) + 1e-12, what
                continue
            if x_differs:
                # Where a QP ran, DAQP may stop a level short of its optimum (1e-6-level
                # residuals) and the levels below then move: the native x must win the first
                # level where the two differ.
                assert method == "cascade", what
                assert lexicographically_no_worse(problem, x_native, x), what
            if method == "cascade" and all(s == "exact" for s in statuses):
                assert np.abs(tau - python.tau).max() <= TAU_TOL, what


# Relative to the total weighted cost: DAQP stops when the objective, not each level, is within
# its tolerance, so a level is resolved only as far as its share of the total. Measured on the
# recorded states: the two kernels' level shares agree within 3.4e-9 of the total where their
# totals agree (1.6e-7 on Solo12 standing, whose total is 5e-12).
LEVEL_SHARE_TOL = 1e-6


@pytest.mark.skipif(not native_available(), reason=NOT_BUILT or "native kernel built")
@pytest.mark.parametrize("name", QUADRUPEDS)
def test_every_level_of_weighted_hutter_table7_agrees(name: str) -> None:
    """hutter_table7 under `weighted` (7 levels, weights 1 down to 1e-15): level by level, the
    weighted cost w_r ‖A_r x − b_r‖² of the native x equals the Python one's within
    LEVEL_SHARE_TOL of the total, not only the total; where the native total is lower by more
    than that (Solo12 trotting: 1.4 % lower, DAQP stopping the Python kernel's QP short) the
    levels may trade, and the native x must be the better one."""
    preset = load_stack_preset("hutter_table7")
    controller, _ = controller_for(name)
    kernel = kernel_of(controller)
    controller.set_stack(Stack.of(preset.levels))
    kernel.set_stack(preset.levels)
    controller.set_hierarchy("weighted")
    kernel.set_method("weighted")
    compared = 0
    for tag, q, v, refs in recorded_states(name):
        controller.references = refs
        controller.robot.update(q, v)
        send_references(kernel, refs)
        python = controller.solve()
        send_python_feedback(controller, kernel)
        _, qdd, forces, ok, message, *_ = kernel.tick(q, v)
        assert ok, f"{name} {tag}: {message}"
        problem = controller.build_problem()
        x, x_native = np.r_[python.qdd, python.forces], np.r_[qdd, forces]
        total, total_native = weighted_cost(problem, x), weighted_cost(problem, x_native)
        if total_native < total * (1.0 - LEVEL_SHARE_TOL):
            continue  # the native kernel found the better point: its levels may differ
        assert total_native <= total * (1.0 + LEVEL_SHARE_TOL), f"{name} {tag}"
        for depth, level in enumerate(problem.levels):
            share = level.weight * np.sum((level.A @ x - level.b) ** 2)
            share_native = level.weight * np.sum((level.A @ x_native - level.b) ** 2)
            what = f"{name} {tag} level {depth} (weight {level.weight:g})"
            assert abs(share_native - share) <= LEVEL_SHARE_TOL * total, what
            compared += 1
    assert compared >= 3 * len(preset.levels)


def test_a_scenario_picks_its_kernel(tmp_path) -> None:
    path = tmp_path / "python_kernel.toml"
    path.write_text('robot = "solo12"\nduration = 0.05\n[controller]\nkernel = "python"\n')
    assert run_scenario(load_scenario(path))["kernel"] == "python"
    path.write_text('robot = "solo12"\nduration = 0.05\n')
    assert run_scenario(load_scenario(path))["kernel"] == "native"
