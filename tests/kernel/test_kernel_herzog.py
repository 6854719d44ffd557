"""The native kernel on Herzog's stacks (issue 12) against the Python controller, its oracle.

Talos under herzog_table2 (double support; the momentum task's `pd`, `lqr` and `lqr_talos` laws)
and herzog_table4 (single support with the swing sole, and with the swinging leg), cascade and
weighted: the rows of each task and constraint these stacks add, and the whole tick (x and τ) on
perturbed states, one of them with a CoP bound binding, and across a contact switch while the
LQR gains interpolate, with K_h crossing into the kernel only while it changes.
"""

import copy
import functools

import numpy as np
import pinocchio as pin
import pytest

from lab.controller.behaviours.stance import Stance
from lab.controller.controller import ControlOutput, WholeBodyController
from lab.controller.model import RobotModel
from lab.controller.native import NOT_BUILT, NativeController, native_available, send_references
from lab.controller.references import SoleReferences
from lab.stack_presets import load_stack_preset
from lab.world.session import Session, SessionConfig
from tests.helpers.controllers import disturbed_state
from tests.helpers.kernel import assert_rows_equal, momentum_gain
from tests.helpers.kernel_herzog import assert_ticks_agree, robot_of, stack_controller

pytest.importorskip("lab._kernel", reason="the native kernel is not built (./dev builds it)")
pytestmark = pytest.mark.skipif(not native_available(), reason=NOT_BUILT or "built")

HERZOG_TASKS = ("momentum", "internal_wrench", "swing_sole", "swing_leg")
HERZOG_CONSTRAINTS = ("cop_inner", "sole_torsion")
RIGHT = 1  # Talos's contacts: the left sole, then the right one


def talos() -> tuple:
    """Talos's description and robot."""
    return robot_of("talos")


def stance_references_at(model: RobotModel, q_standing: np.ndarray) -> SoleReferences:
    """The stance behaviour's references, the model at its standing posture."""
    return Stance(model, q_standing).references


def controller_of(kind: type, preset: str, method: str, mode: str) -> WholeBodyController:
    """A controller of class `kind` for Talos under stack preset `preset` (its gains), hierarchy
    `method` and momentum law `mode`, the stance behaviour's references."""
    stack = load_stack_preset(preset)
    controller = stack_controller(
        kind, "talos", stack.levels, stack.gains, method, stance_references_at
    )
    controller.set_momentum_mode(mode)
    return controller


@functools.cache
def stance_references() -> SoleReferences:
    """The stance behaviour's references at Talos's standing posture (both soles down)."""
    _, robot = talos()
    model = RobotModel(robot.model, robot.contacts)
    model.update(robot.q_standing, np.zeros(robot.model.nv))
    return stance_references_at(model, robot.q_standing)


def sole_references(stance: str) -> SoleReferences:
    """The stance references in `stance`: `double`, `single` (the right sole out of support, its
    target 10 cm up and tilted) or `swing` (and its leg on a joint trajectory)."""
    refs = copy.deepcopy(stance_references())
    if stance != "double":
        refs.contact_active[RIGHT] = False
        refs.sole_position[RIGHT, 2] += 0.1
        tilt = pin.rpy.rpyToMatrix(0.05, -0.1, 0.02)
        refs.sole_rotation[RIGHT] = tilt @ refs.sole_rotation[RIGHT]
    if stance == "swing":
        rng = np.random.default_rng(3)
        refs.leg_swinging[RIGHT] = True
        refs.leg_position += rng.normal(0.0, 0.1, len(refs.leg_position))
        refs.leg_velocity[:] = rng.normal(0.0, 0.3, len(refs.leg_position))
        refs.leg_acceleration[:] = rng.normal(0.0, 1.0, len(refs.leg_position))
    return refs


def test_rows_of_herzogs_tasks_and_constraints_agree() -> None:
    """The rows the Herzog stacks add, on random states and sole references (both soles down,
    one lifted, its leg swinging), random gains and CoG references, the momentum task in each
    of its laws."""
    _, robot = talos()
    python = controller_of(WholeBodyController, "herzog_table4", "cascade", "pd")
    native = controller_of(NativeController, "herzog_table4", "cascade", "pd")
    kernel, model = native._native, python.robot
    rng = np.random.default_rng(12)
    cases = [("double", "pd"), ("single", "lqr"), ("swing", "lqr_talos"), ("single", "pd")]
    for i, (stance, mode) in enumerate(cases):
        what = f"state {i} {stance} {mode}"
        q, v = disturbed_state(robot, rng)
        model.update(q, v)
        kernel.update(q, v)
        refs = sole_references(stance)
        refs.com = model.com + rng.normal(0.0, 0.03, 3)
        refs.com_velocity = rng.normal(0.0, 0.1, 3)
        send_references(kernel, refs)
        python.set_momentum_mode(mode)
        for name in HERZOG_TASKS:
            kp, kd = rng.uniform(1.0, 400.0, 2)
            python.set_gains(name, kp, kd, 1.0)
            kernel.set_gains(name, kp, kd, 1.0)
            want = python.tasks[name].rows(model, refs)
            if name == "momentum":
                kernel.set_momentum_gain(momentum_gain(python))
            assert_rows_equal(kernel.rows(name), want[:2], f"{what}: {name}")
        for name in HERZOG_CONSTRAINTS:
            assert_rows_equal(kernel.rows(name), python.constraints[name].rows(model, refs), what)


def perturbed_states(stance: str, seed: int) -> list[tuple[str, np.ndarray, np.ndarray, object]]:
    """(tag, q, v, references) near Talos's standing posture: three perturbed states and one
    whose CoG reference lies 6 cm ahead, at rest."""
    _, robot = talos()
    rng = np.random.default_rng(seed)
    states = []
    for i in range(3):
        states.append(
            (f"{stance} perturbed {i}", *disturbed_state(robot, rng), sole_references(stance))
        )
    refs = sole_references(stance)
    refs.com = refs.com + np.array([0.06, 0.0, 0.0])
    states.append((f"{stance} CoG ahead", robot.q_standing, np.zeros(robot.model.nv), refs))
    return states


def cop_binds(controller: WholeBodyController, output: ControlOutput) -> bool:
    """Whether a row of `cop_inner` holds with equality at the output's x."""
    C, d = controller.constraints["cop_inner"].rows(controller.robot, controller.references)
    return bool(np.any(np.abs(C @ np.r_[output.qdd, output.forces] - d) < 1e-9))


@pytest.mark.parametrize("method", ["cascade", "weighted"])
@pytest.mark.parametrize("mode", ["pd", "lqr", "lqr_talos"])
def test_the_table2_tick_agrees_with_python(mode: str, method: str) -> None:
    """herzog_table2 in double support: x and τ of the two kernels, a CoP bound binding in some
    of the states."""
    python = controller_of(WholeBodyController, "herzog_table2", method, mode)
    native = controller_of(NativeController, "herzog_table2", method, mode)
    binding = 0
    for tag, q, v, refs in perturbed_states("double", seed=4):
        python.references = refs
        output = assert_ticks_agree(python, native, q, v, f"table2 {mode} {method} {tag}")
        binding += cop_binds(python, output)
    assert binding > 0, "no state had a CoP bound binding"


@pytest.mark.parametrize("method", ["cascade", "weighted"])
@pytest.mark.parametrize("stance", ["single", "swing"])
def test_the_table4_tick_agrees_with_python(stance: str, method: str) -> None:
    """herzog_table4 on the left sole, the right one lifted (swing_sole) or its leg swinging
    (swing_leg), the momentum task's LQR law."""
    python = controller_of(WholeBodyController, "herzog_table4", method, "lqr")
    native = controller_of(NativeController, "herzog_table4", method, "lqr")
    for tag, q, v, refs in perturbed_states(stance, seed=5):
        python.references = refs
        output = assert_ticks_agree(python, native, q, v, f"table4 {method} {tag}")
        task = "swing_leg" if stance == "swing" else "swing_sole"
        assert output.task_errors[task] > 0.0, tag


@pytest.mark.parametrize("method", ["cascade", "weighted"])
def test_a_contact_switch_during_the_lqr_gain_interpolation_agrees(method: str) -> None:
    """herzog_table4 with the LQR law: double support, then the right sole leaves support and
    K_h is interpolated over the next ticks (10 here) to the single-support design, at one
    perturbed state (only K_h and the contacts change). Every tick agrees with Python; the
    kernel asks the Python schedule once at the switch and steps the interpolation itself (nor
    while double support was settled), and the schedule caught up with those steps holds the
    K_h Python's does."""
    _, robot = talos()
    python = controller_of(WholeBodyController, "herzog_table4", method, "lqr")
    native = controller_of(NativeController, "herzog_table4", method, "lqr")
    for controller in (python, native):
        controller.tasks["momentum"].schedule.transition_ticks = 10
    task = native.tasks["momentum"]
    asked = []
    schedule_tick = task._schedule_tick
    task._schedule_tick = lambda steps: asked.append(1) or schedule_tick(steps)  # the kernel's
    q, v = disturbed_state(robot, np.random.default_rng(6))
    refs = sole_references("double")
    python.references = refs
    crossings = []
    for t in range(24):
        if t == 12:
            refs.contact_active[RIGHT] = False  # the right sole leaves support
        before = len(asked)
        assert_ticks_agree(python, native, q, v, f"{method} tick {t}")
        crossings.append(len(asked) - before)
    # Double support: the first tick starts the schedule at its design (no interpolation): it
    # crosses once.
    assert crossings[:12] == [1] + [0] * 11
    assert crossings[12:] == [1] + [0] * 11
    gain = python.tasks["momentum"].schedule.current
    native.momentum_gain_in_use()  # the schedule caught up with the kernel's steps
    np.testing.assert_array_equal(task.schedule.current, gain)


@pytest.mark.parametrize(
    ("robot", "commands"),
    [
        ("talos", [("stack", {"preset": "herzog_table2"}), ("momentum", {"mode": "lqr"})]),
        ("talos", [("stance", {"side": "left"})]),  # brings herzog_table4
        ("bolt", []),  # the default stack, with internal_force
    ],
)
def test_herzog_and_kim_stacks_run_on_the_native_kernel_by_default(
    robot: str, commands: list[tuple[str, dict]]
) -> None:
    """A session on Herzog's presets, the stance behaviour's stack or Bolt's default stack runs
    native (no Python-only task type left) without a note."""
    session = Session(SessionConfig(robot=robot))
    for verb, payload in commands:
        assert session.handle(verb, payload)["ok"]
    for _ in range(20):
        session.tick()
    telemetry = session.telemetry()
    assert (telemetry["kernel"], telemetry["kernel_note"]) == ("native", "")
    assert session.qp_failures == 0


def test_bad_gains_commands_and_sole_references_raise_clear_errors_and_change_nothing() -> None:
    _, robot = talos()
    python = controller_of(WholeBodyController, "herzog_table4", "cascade", "pd")
    kernel = controller_of(NativeController, "herzog_table4", "cascade", "pd")._native
    model = python.robot
    kernel.update(robot.q_standing, np.zeros(robot.model.nv))
    refs = sole_references("single")
    send_references(kernel, refs)
    with pytest.raises(RuntimeError, match="momentum: no K_h was set"):
        kernel.rows("momentum")
    python.tasks["momentum"].rows(model, refs)
    kernel.set_momentum_gain(momentum_gain(python))
    before = kernel.rows("momentum")
    with pytest.raises(ValueError, match="K_h needs 6 x 9 entries, got 3 x 3"):
        kernel.set_momentum_gain(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="K_h has non-finite entries"):
        kernel.set_momentum_gain(np.full((6, 9), np.nan))
    assert_rows_equal(kernel.rows("momentum"), before, "after the rejected gains")
    with pytest.raises(ValueError, match="internal_force: the reference must be finite"):
        kernel.set_internal_force(np.nan, "contacts")
    with pytest.raises(ValueError, match="unknown source 'feet'"):
        kernel.set_internal_force(1.0, "feet")
    with pytest.raises(ValueError, match="sensing: foot_forces has 3 entries"):
        kernel.set_sensing(np.zeros(3), np.zeros(model.na))
    with pytest.raises(ValueError, match="sensing: applied_torques has non-finite"):
        kernel.set_sensing(np.zeros((2, 3)), np.full(model.na, np.nan))
    bad = copy.deepcopy(refs)
    bad.sole_position = np.zeros((1, 3))
    with pytest.raises(ValueError, match="sole_position has 3 entries"):
        send_references(kernel, bad)
    bad = copy.deepcopy(refs)
    bad.leg_swinging[RIGHT] = True
    bad.leg_velocity = np.zeros(2)
    tau, x = np.zeros(model.na), np.zeros(model.nx)
    with pytest.raises(ValueError, match="leg_velocity has 2 entries"):
        kernel.tick_into(bad, tau, x)
    assert not tau.any()
    kernel.set_stack(python.config.stack.as_lists())
    assert kernel.tick_into(refs, tau, x).ok  # the kernel works after every rejected call
