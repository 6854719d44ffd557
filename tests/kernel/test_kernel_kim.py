"""The native kernel on Kim's tasks (issue 12) against the Python controller, its oracle.

Bolt under the foot-line stack of the Kim wedge scenarios (`com_along_feet`, `com_across_feet`,
`internal_force`), cascade and weighted: x and τ of the two kernels on perturbed standing states,
the internal force's feedback sensed from the feet's forces and from the joint torques (Kim eqs.
12–13), computed by each kernel from the same sensed values.
"""

from pathlib import Path

import numpy as np
import pytest

from lab.controller.behaviours.balance import standing_references
from lab.controller.behaviours.biped_step import BipedStepping
from lab.controller.controller import WholeBodyController
from lab.controller.native import (
    NOT_BUILT,
    NativeController,
    kernel_for,
    native_available,
    send_references,
)
from lab.experiments.scenario import load_scenario
from tests.helpers.controllers import controller_for, disturbed_state
from tests.helpers.kernel_herzog import assert_ticks_agree, robot_of, stack_controller

pytest.importorskip("lab._kernel", reason="the native kernel is not built (./dev builds it)")
pytestmark = pytest.mark.skipif(not native_available(), reason=NOT_BUILT or "built")
SCENARIOS = Path(__file__).resolve().parent.parent.parent / "scenarios"


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
        for value in ("sensed", "command"):  # the kernel's feedback, as telemetry reads it
            np.testing.assert_allclose(
                getattr(native.internal_force, value),
                getattr(python.internal_force, value),
                rtol=0,
                atol=1e-9,
            )


def test_the_swing_feet_task_tracks_the_feet_biped_step_names_on_both_kernels() -> None:
    """biped_step keeps the swinging foot in `swing_feet` through the lift and land transitions,
    while the foot is still in contact (`WalkReferences.swing_tracked`): the kernel's rows are
    the Python task's at every tick of a step (the C++ task once read the contact flags only)."""
    controller, robot = controller_for("bolt")
    model = controller.robot
    model.update(robot.q_standing, np.zeros(robot.model.nv))
    stepping = BipedStepping(model, robot.q_standing)
    kernel = kernel_for(controller)
    kernel.set_gains("swing_feet", 100.0, 20.0, 1.0)
    controller.set_gains("swing_feet", 100.0, 20.0, 1.0)
    kernel.update(robot.q_standing, np.zeros(robot.model.nv))
    task = controller.tasks["swing_feet"]
    tracked_in_contact = 0
    for tick in range(300):
        stepping.update(1e-3 * tick, model, np.zeros(3), np.ones(2, dtype=bool))
        refs = stepping.references
        tracked_in_contact += bool(np.any(refs.swing_tracked & refs.contact_active))
        send_references(kernel, refs)
        A, b, _ = task.rows(model, refs)
        native_A, native_b = kernel.rows("swing_feet")
        what = f"tick {tick} ({stepping.phase.value})"
        assert native_A.shape == A.shape, what
        np.testing.assert_allclose(native_A, A, rtol=0, atol=1e-12, err_msg=what)
        np.testing.assert_allclose(native_b, b, rtol=0, atol=1e-9, err_msg=what)
    assert tracked_in_contact >= 20  # both transitions, 20 ms each, were among the ticks
