"""The native kernel (lab._kernel) against the Python controller, its oracle.

Same model (pinocchio's serialization), same rows for every task and constraint on random states
and references of every robot, the same hierarchy problem for every stack preset, and clear
errors for bad input. Skipped as a whole when the kernel is not built.
"""

import numpy as np
import pinocchio as pin
import pytest

from lab.controller.behaviours.balance import standing_references
from lab.controller.constraints import ContactLimits
from lab.controller.controller import ControllerConfig, WholeBodyController
from lab.controller.model import RobotModel
from lab.controller.native import NOT_BUILT, NativeController, send_references
from lab.controller.stack import Stack
from lab.controller.walk_references import WalkReferences
from lab.description import ROBOT_NAMES, build_robot, load_description
from lab.stack_presets import PRESET_NAMES, load_stack_preset

_kernel = pytest.importorskip(
    "lab._kernel", reason="the native kernel is not built (./dev builds it)"
)

ROWS_TOL = 1e-9  # relative to the entries' scale: the same pinocchio calls, other float order
STATES = 6  # random states per robot


def python_controller(name: str) -> tuple[WholeBodyController, object]:
    description = load_description(name)
    robot = build_robot(description)
    model = RobotModel(robot.model, robot.contacts)
    config = ControllerConfig(
        Stack.of(description.stack),
        dict(description.gains),
        limits=ContactLimits(friction=description.friction),
        kernel="python",
    )
    refs = standing_references(model, robot.q_standing)
    return WholeBodyController(model, refs, config, robot.torque_limits), robot


def kernel_of(controller: WholeBodyController) -> "_kernel.Kernel":
    """A kernel with the controller's model, limits and gains."""
    robot, limits = controller.robot, controller.config.limits
    joints = controller.constraints["joint_limits"]
    kernel = _kernel.Kernel(
        robot.model.saveToString(),
        [(c.name, c.frame, c.kind, c.radius, c.half_length, c.half_width) for c in robot.contacts],
        controller.constraints["torque_limits"].torque_limits,
        joints.lower,
        joints.upper,
        limits.friction,
        limits.normal_min,
        limits.normal_max,
    )
    for name, task in controller.tasks.items():
        kernel.set_gains(name, task.gains.kp, task.gains.kd, task.gains.weight)
    return kernel


def random_state(robot, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    q = robot.q_standing.copy()
    q[7:] += rng.uniform(-0.2, 0.2, len(q) - 7)
    q[:3] += rng.uniform(-0.1, 0.1, 3)
    q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(*rng.uniform(-0.3, 0.3, 3))).coeffs()
    return q, rng.normal(0.0, 0.5, robot.model.nv)


def random_references(model: RobotModel, rng: np.random.Generator, walk: bool) -> WalkReferences:
    """References with every field set; `walk=False` leaves the walking fields empty."""
    n = len(model.contacts)
    active = rng.random(n) < 0.5
    active[rng.integers(n)] = True
    refs = WalkReferences(
        com=model.com + rng.normal(0.0, 0.05, 3),
        posture=model.q[7:] + rng.normal(0.0, 0.1, model.na),
        base_height=float(model.q[2] + rng.normal(0.0, 0.05)),
        base_rotation=pin.rpy.rpyToMatrix(*rng.uniform(-0.3, 0.3, 3)),
        com_velocity=rng.normal(0.0, 0.2, 3),
        base_angular_velocity=rng.normal(0.0, 0.2, 3),
        contact_active=active,
        normal_force_max=rng.uniform(100.0, 900.0, n) if rng.random() < 0.5 else np.zeros(0),
        base_linear_velocity=rng.normal(0.0, 0.3, 3),
    )
    if walk:
        normals = rng.normal(0.0, 0.3, (n, 3)) + np.array([0.0, 0.0, 1.0])
        weights = rng.uniform(0.0, 1.0, n)
        weights[rng.random(n) < 0.4] = np.nan
        posture_weight = rng.uniform(0.0, 1.0, n)
        posture_weight[rng.random(n) < 0.3] = 0.0
        refs.foot_position = model.contact_positions + rng.normal(0.0, 0.05, (n, 3))
        refs.foot_velocity = rng.normal(0.0, 0.3, (n, 3))
        refs.foot_acceleration = rng.normal(0.0, 1.0, (n, 3))
        refs.surface_normal = normals / np.linalg.norm(normals, axis=1, keepdims=True)
        refs.force_weight = weights
        refs.posture_velocity = rng.normal(0.0, 0.3, model.na)
        refs.posture_weight = posture_weight
    return refs


def random_gains(controller: WholeBodyController, kernel, rng: np.random.Generator) -> None:
    """Nonzero gains on every task (the robots' own leave most of them zero), both sides."""
    for name in controller.tasks:
        kp, kd = rng.uniform(1.0, 400.0, 2)
        weight = 1.0 if rng.random() < 0.5 else float(rng.uniform(1e-3, 10.0))
        controller.set_gains(name, kp, kd, weight)
        kernel.set_gains(name, kp, kd, weight)


def assert_rows_equal(native: tuple, python: tuple, what: str) -> None:
    for got, want in zip(native, python, strict=True):
        want = np.asarray(want, dtype=float)
        assert got.shape == want.shape, f"{what}: shape {got.shape} != {want.shape}"
        scale = 1.0 + (np.abs(want).max() if want.size else 0.0)
        np.testing.assert_allclose(got, want, rtol=0.0, atol=ROWS_TOL * scale, err_msg=what)


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_the_kernel_loads_the_same_model(name: str) -> None:
    controller, robot = python_controller(name)
    kernel = kernel_of(controller)
    model = robot.model
    assert (kernel.nq, kernel.nv) == (model.nq, model.nv)
    assert kernel.nf == controller.robot.nf and kernel.nx == controller.robot.nx
    assert kernel.frame_names() == [frame.name for frame in model.frames]
    inertias = np.array([inertia.toDynamicParameters() for inertia in model.inertias])
    np.testing.assert_allclose(kernel.inertias(), inertias, rtol=1e-12, atol=1e-12)
    assert kernel.mass == pytest.approx(controller.robot.mass, rel=1e-12)


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_rows_of_every_task_and_constraint_agree(name: str) -> None:
    controller, robot = python_controller(name)
    kernel = kernel_of(controller)
    model = controller.robot
    assert sorted(kernel.known_names()) == sorted(controller.known_names)
    rng = np.random.default_rng(12)
    for i in range(STATES):
        q, v = random_state(robot, rng)
        model.update(q, v)
        kernel.update(q, v)
        refs = random_references(model, rng, walk=i % 2 == 0)
        send_references(kernel, refs)
        random_gains(controller, kernel, rng)
        for task_name, task in controller.tasks.items():
            python = task.rows(model, refs)
            native = kernel.rows(task_name)
            assert_rows_equal(native, python, f"{name} state {i}: task {task_name}")
        for constraint_name, constraint in controller.constraints.items():
            python = constraint.rows(model, refs)
            native = kernel.rows(constraint_name)
            assert_rows_equal(native, python, f"{name} state {i}: {constraint_name}")


def stacks_of(name: str) -> list[tuple[str, list[list[str]]]]:
    """The robot's default stack and every preset."""
    default = [list(level) for level in load_description(name).stack]
    return [("default", default)] + [(p, load_stack_preset(p).levels) for p in PRESET_NAMES]


@pytest.mark.parametrize("name", ROBOT_NAMES)
def test_the_hierarchy_problem_of_every_stack_agrees(name: str) -> None:
    controller, robot = python_controller(name)
    kernel = kernel_of(controller)
    model = controller.robot
    rng = np.random.default_rng(5)
    for stack_name, levels in stacks_of(name):
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
    controller, robot = python_controller("anymal")
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
    with pytest.raises(KeyError, match="no hierarchy method 'nullspace'"):
        kernel.set_method("nullspace")
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


def test_a_stack_the_kernel_lacks_runs_on_python_and_says_so() -> None:
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
