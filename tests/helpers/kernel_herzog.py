"""Herzog's stacks on both kernels, tick by tick (from tests/kernel/test_kernel_herzog.py)."""

import functools
from collections.abc import Callable

import numpy as np
import pytest

from lab.controller.constraints import ContactLimits
from lab.controller.controller import ControllerConfig, ControlOutput, WholeBodyController
from lab.controller.model import RobotModel
from lab.controller.native import NativeController
from lab.controller.stack import Stack
from lab.description import load_description
from lab.robot import build_robot
from tests.helpers.kernel import ROWS_TOL, WEIGHTED_COST_TOL

X_TOL = 1e-8  # relative to 1 + |x|
TAU_TOL = 1e-6  # N m


@functools.cache
def robot_of(name: str) -> tuple:
    """A robot's description and robot, built once."""
    description = load_description(name)
    return description, build_robot(description)


def stack_controller(
    kind: type, name: str, levels: list, gains: dict, method: str, references: Callable
) -> WholeBodyController:
    """A controller of class `kind` for robot `name` on its own model at the standing posture:
    stack `levels`, the robot's gains with `gains` (task → kp, kd, weight) over them, hierarchy
    `method`, the references `references(model, q_standing)`."""
    description, robot = robot_of(name)
    model = RobotModel(robot.model, robot.contacts)
    model.update(robot.q_standing, np.zeros(robot.model.nv))
    config = ControllerConfig(
        Stack.of(levels),
        dict(description.gains),
        method,
        limits=ContactLimits(friction=description.friction),
    )
    refs = references(model, robot.q_standing)
    controller = kind(model, refs, config, robot.torque_limits)
    for task, values in gains.items():
        controller.set_gains(task, **values)
    return controller


def tick(controller: WholeBodyController, q: np.ndarray, v: np.ndarray) -> ControlOutput:
    controller.update(q, v)
    return controller.solve()


def assert_ticks_agree(
    python: WholeBodyController, native: NativeController, q: np.ndarray, v: np.ndarray, what: str
) -> ControlOutput:
    """One tick of each at (q, v) on the Python one's references: the native kernel ran, with
    the same task errors, x within X_TOL and τ within TAU_TOL. Where the weighted optimum is flat
    (the soles' internal forces weigh 1e-7 against the contacts' 1e4) and x differs, the native
    x satisfies every constraint and its weighted cost is no higher (test_kernel's rule).
    Returns the Python output."""
    native.references = python.references
    want, got = tick(python, q, v), tick(native, q, v)
    assert native.kernel_ran == "native", f"{what}: {native.kernel_note}"
    assert got.task_errors.keys() == want.task_errors.keys(), what
    for task, error in got.task_errors.items():
        assert error == pytest.approx(want.task_errors[task], rel=ROWS_TOL, abs=ROWS_TOL), what
    x, x_native = np.r_[want.qdd, want.forces], np.r_[got.qdd, got.forces]
    atol = X_TOL * (1.0 + np.abs(x).max())
    # A flat weighted optimum moves τ too: with the lifted sole's force columns out of the QP
    # (both kernels), x differed by 1.6e-6 and τ by 1.5e-6 N m at costs equal to 1e-15 relative
    # (measured 2026-12-03): τ beyond TAU_TOL is then judged by the cost as x is.
    differs = np.abs(x_native - x).max() > atol or np.abs(got.tau - want.tau).max() > TAU_TOL
    if python.config.method == "weighted" and differs:
        levels = native._native.problem()["levels"]  # this tick's rows, K_h as handed over
        for _, _, C, d, _ in levels:
            assert np.all(C @ x_native <= d + X_TOL * (1.0 + np.abs(d))), what
        cost, cost_native = weighted_cost(levels, x), weighted_cost(levels, x_native)
        assert cost_native <= cost * (1.0 + WEIGHTED_COST_TOL) + 1e-12, what
        return want
    np.testing.assert_allclose(x_native, x, rtol=0, atol=atol, err_msg=what)
    np.testing.assert_allclose(got.tau, want.tau, rtol=0, atol=TAU_TOL, err_msg=what)
    return want


def weighted_cost(levels: list[tuple], x: np.ndarray) -> float:
    """The weighted method's objective (hierarchy/weighted.py) on the kernel's levels."""
    lightest = min(level[4] for level in levels)
    cost = sum(w * np.sum((A @ x - b) ** 2) for A, b, _, _, w in levels)
    return float(cost + 1e-9 * lightest * x @ x)
