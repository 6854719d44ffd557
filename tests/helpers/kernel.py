"""The native kernel beside its Python oracle: tolerances, row comparison, feedback sent to both
(from tests/kernel/test_kernel.py)."""

import numpy as np
import pinocchio as pin
import pytest

from lab.controller.controller import WholeBodyController
from lab.controller.momentum import pd_gain
from lab.controller.native import (
    kernel_for,
)

_kernel = pytest.importorskip(
    "lab._kernel", reason="the native kernel is not built (./dev builds it)"
)
ROWS_TOL = 1e-9  # relative to the entries' scale: the same pinocchio calls, other float order


def kernel_of(controller: WholeBodyController) -> "_kernel.Kernel":
    """A kernel with the controller's model, limits and gains."""
    kernel = kernel_for(controller)
    for name, task in controller.tasks.items():
        kernel.set_gains(name, task.gains.kp, task.gains.kd, task.gains.weight)
    return kernel


def momentum_gain(controller: WholeBodyController) -> np.ndarray:
    """The K_h the Python momentum task used at its last rows, for the kernel (as NativeController
    hands it over)."""
    task = controller.tasks["momentum"]
    if task.mode == "pd":
        return pd_gain(controller.robot.mass, task.gains.kp, task.gains.kd)
    return task.schedule.current


def send_python_feedback(controller: WholeBodyController, kernel) -> None:
    """What NativeController hands the kernel from the Python tasks, for the stack's tasks: the
    momentum task's K_h of the last rows and the internal force's reference, source and what
    was sensed (its feedback, Kim eq. 12, runs in the kernel)."""
    names = controller.config.stack.names()
    if "momentum" in names:
        kernel.set_momentum_gain(momentum_gain(controller))
    if "internal_force" in names:
        send_internal_force(controller, kernel)


def send_internal_force(controller: WholeBodyController, kernel) -> None:
    """The internal-force task's reference, sensed source and sensed values, into the kernel."""
    task = controller.internal_force
    kernel.set_internal_force(task.reference, task.source)
    if task.measured_forces is not None:
        kernel.set_sensing(task.measured_forces, task.applied_torques)


def random_state(robot, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    q = robot.q_standing.copy()
    q[7:] += rng.uniform(-0.2, 0.2, len(q) - 7)
    q[:3] += rng.uniform(-0.1, 0.1, 3)
    q[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(*rng.uniform(-0.3, 0.3, 3))).coeffs()
    return q, rng.normal(0.0, 0.5, robot.model.nv)


def assert_rows_equal(native: tuple, python: tuple, what: str) -> None:
    for got, want in zip(native, python, strict=True):
        want = np.asarray(want, dtype=float)
        assert got.shape == want.shape, f"{what}: shape {got.shape} != {want.shape}"
        scale = 1.0 + (np.abs(want).max() if want.size else 0.0)
        np.testing.assert_allclose(got, want, rtol=0.0, atol=ROWS_TOL * scale, err_msg=what)


WEIGHTED_COST_TOL = 1e-9  # relative: above it, the weighted costs of two x are not the same
