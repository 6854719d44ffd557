"""The native kernel on Kim's tasks (issue 12) against the Python controller, its oracle.

Bolt under the foot-line stack of the Kim wedge scenarios (`com_along_feet`, `com_across_feet`,
`internal_force`), cascade and weighted: x and τ of the two kernels on perturbed standing states,
the internal force's feedback sensed from the feet's forces and from the joint torques (Kim eqs.
12–13), computed by the Python task and handed to the kernel every tick.
"""

from pathlib import Path

import numpy as np
import pytest

from lab.controller.behaviours.balance import standing_references
from lab.controller.controller import WholeBodyController
from lab.controller.native import NOT_BUILT, NativeController, native_available
from lab.server.scenario import load_scenario
from tests.test_controller import disturbed_state
from tests.test_kernel_herzog import assert_ticks_agree, robot_of, stack_controller

pytest.importorskip("lab._kernel", reason="the native kernel is not built (./dev builds it)")
pytestmark = pytest.mark.skipif(not native_available(), reason=NOT_BUILT or "built")
SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


def bolt_controller(kind: type, method: str, source: str) -> WholeBodyController:
    """A controller of class `kind` for Bolt under the stack and gains of the sideways wedge
    scenario, the internal force sensed from `source` towards 0.6 N of tension."""
    scenario = load_scenario(SCENARIOS / "kim_wedges_impedance_side.toml").config
    controller = stack_controller(
        kind, "bolt", scenario.stack, scenario.gains, method, standing_references
    )
    task = controller.internal_force
    task.set_source(source)
    task.reference = 0.6
    return controller


@pytest.mark.parametrize("method", ["cascade", "weighted"])
@pytest.mark.parametrize("source", ["contacts", "torques"])
def test_the_foot_line_stack_with_internal_force_feedback_agrees(method: str, source: str) -> None:
    """Four perturbed states, the first without a sensed step yet (the command is the
    reference), the others with the feet's measured forces and the applied torques."""
    python = bolt_controller(WholeBodyController, method, source)
    native = bolt_controller(NativeController, method, source)
    _, robot = robot_of("bolt")
    rng = np.random.default_rng(9)
    weight = python.robot.mass * 9.81
    for i in range(4):
        q, v = disturbed_state(robot, rng)
        if i:
            forces = np.array([[0.3, -0.4, weight / 2], [-0.2, 0.5, weight / 2]])
            forces += rng.normal(0.0, 0.2, forces.shape)
            torques = rng.normal(0.0, 0.5, python.robot.na)
            for controller in (python, native):
                controller.set_sensing(forces, torques)
        output = assert_ticks_agree(python, native, q, v, f"bolt {method} {source} state {i}")
        assert set(output.task_errors) >= {"com_along_feet", "com_across_feet"}
        assert ("internal_force" in output.task_errors) == (i > 0)
        np.testing.assert_array_equal(native.internal_force.command, python.internal_force.command)
