"""The whole-body controller on real robot models: physics of the solution it returns."""

import numpy as np
import pinocchio as pin
import pytest

from lab.controller.behaviours import BEHAVIOURS
from lab.controller.model import RobotModel
from lab.controller.stack import Stack, StackError
from lab.description import load_description
from lab.robot import build_robot
from tests.helpers.controllers import controller_for, disturbed_state

ROBOTS = ("anymal", "hyq", "solo12", "talos")
DYNAMICS_TOL = 1e-8  # N or N m: Newton–Euler rows and the torque identity hold to round-off
# rad/s²: a level solved by QP keeps its optimum exactly (3e-12 measured; 1e-5 when the level QP
# carried ε‖x‖² in its objective), up to DAQP's tolerance on the rows that bind.
STRICT_LEVEL_TOL = 1e-8
LIMIT_TOL = 1e-6  # N: friction and force bounds, DAQP's primal tolerance
# Relative, DAQP vs Clarabel on the same robot problem. Where a torque limit is active the
# interior-point answer sits a little inside the limit (Clarabel's 1e-8 tolerance), and the
# smallest-x choice inside a level's optimal set moves with it (1e-4 measured on Talos).
BACKEND_TOL = 1e-3


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("method", ["cascade", "weighted"])
def test_solution_obeys_the_equations_of_motion(name: str, method: str) -> None:
    controller, robot = controller_for(name, method)
    model = controller.robot
    rng = np.random.default_rng(0)
    for _ in range(5):
        q, v = disturbed_state(robot, rng)
        out = controller.compute(q, v)
        # Independent check with pinocchio's RNEA: M q̈ + h − Jcᵀ F = [0; τ].
        generalized = pin.rnea(robot.model, pin.Data(robot.model), q, v, out.qdd)
        generalized -= model.Jc.T @ out.forces
        assert np.max(np.abs(generalized[:6])) <= DYNAMICS_TOL * max(1.0, model.mass)
        assert np.allclose(generalized[6:], out.tau, atol=DYNAMICS_TOL * max(1.0, model.mass))


@pytest.mark.parametrize("name", ROBOTS)
def test_forces_respect_friction_and_unilaterality(name: str) -> None:
    controller, robot = controller_for(name)
    model = controller.robot
    mu = np.sqrt(0.5) * controller.config.limits.friction
    rng = np.random.default_rng(1)
    for _ in range(5):
        out = controller.compute(*disturbed_state(robot, rng))
        for rows in model.force_slices:
            f = out.forces[rows]
            assert f[2] >= -LIMIT_TOL
            assert abs(f[0]) <= mu * f[2] + LIMIT_TOL
            assert abs(f[1]) <= mu * f[2] + LIMIT_TOL
        assert np.all(np.abs(out.tau) <= robot.torque_limits + LIMIT_TOL)


def test_flat_feet_keep_the_centre_of_pressure_inside_the_sole() -> None:
    controller, robot = controller_for("talos")
    model = controller.robot
    rng = np.random.default_rng(2)
    for _ in range(5):
        out = controller.compute(*disturbed_state(robot, rng))
        for contact, rows in zip(model.contacts, model.force_slices, strict=True):
            # CoP = (−τ_y, τ_x) / f_z inside the sole, written without dividing by f_z.
            fz, tx, ty = out.forces[rows][[2, 3, 4]]
            assert fz >= -LIMIT_TOL
            assert abs(ty) <= contact.half_length * fz + LIMIT_TOL
            assert abs(tx) <= contact.half_width * fz + LIMIT_TOL


@pytest.mark.parametrize("name", ROBOTS)
def test_standing_still_needs_no_acceleration_and_carries_the_weight(name: str) -> None:
    controller, robot = controller_for(name)
    model = controller.robot
    out = controller.compute(robot.q_standing, np.zeros(model.nv))
    weight = model.mass * 9.81
    # Point feet carry world-frame forces; flat feet a wrench in the sole frame.
    vertical = sum(
        (model.contact_rotations[i] @ out.forces[rows][:3])[2]
        if c.kind == "flat"
        else out.forces[rows][2]
        for i, (c, rows) in enumerate(zip(model.contacts, model.force_slices, strict=True))
    )
    assert vertical == pytest.approx(weight, rel=1e-6)
    # CoM and base orientation are at their references: their level asks zero acceleration and
    # gets it exactly (the lowest level may still trade joint accelerations against forces).
    com_acceleration = model.Jcom @ out.qdd + model.com_drift
    assert np.max(np.abs(com_acceleration)) < 1e-8
    assert np.max(np.abs(out.qdd[3:6])) < 1e-8


@pytest.mark.parametrize("name", ["anymal", "talos"])
def test_daqp_and_clarabel_agree_on_robot_problems(name: str) -> None:
    rng = np.random.default_rng(3)
    fast, robot = controller_for(name, solver="daqp")
    reference, _ = controller_for(name, solver="clarabel")
    for _ in range(3):
        q, v = disturbed_state(robot, rng)
        a, b = fast.compute(q, v), reference.compute(q, v)
        assert np.linalg.norm(a.tau - b.tau) <= BACKEND_TOL * max(1.0, np.linalg.norm(b.tau))
        assert np.linalg.norm(a.forces - b.forces) <= BACKEND_TOL * np.linalg.norm(b.forces)


def test_a_higher_task_is_untouched_by_the_levels_below() -> None:
    """Base orientation alone below the contacts vs. with posture and forces under it."""
    controller, robot = controller_for("anymal")
    q, v = disturbed_state(robot, np.random.default_rng(4))
    controller.set_stack(
        Stack.of([["friction", "torque_limits"], ["contact"], ["base_orientation"]])
    )
    alone = controller.compute(q, v)
    A, b, _ = controller.tasks["base_orientation"].rows(controller.robot, controller.references)
    residual_alone = np.linalg.norm(A[:, : len(alone.qdd)] @ alone.qdd - b)
    controller.set_stack(
        Stack.of([["friction", "torque_limits"], ["contact"], ["base_orientation"], ["posture"]])
    )
    full = controller.compute(q, v)
    residual_full = np.linalg.norm(A[:, : len(full.qdd)] @ full.qdd - b)
    assert abs(residual_full - residual_alone) <= STRICT_LEVEL_TOL
    assert np.linalg.norm(full.qdd - alone.qdd) > 1e-3  # the posture level did change q̈


def test_a_bad_stack_is_rejected_and_the_old_one_kept() -> None:
    controller, _ = controller_for("anymal")
    before = controller.config.stack
    for levels in ([["contact"], ["no_such_task"]], [["contact", "contact"]], [[]], []):
        with pytest.raises(StackError):
            controller.set_stack(Stack.of(levels))
        assert controller.config.stack == before


@pytest.mark.parametrize("name", ["anymal", "solo12"])
def test_a_level_with_no_freedom_left_changes_nothing(name: str) -> None:
    """Posture alone below contact, CoM and orientation: four feet leave q̈ no freedom (only the
    internal forces are free), so the posture level must not move x. Its projected rows are
    round-off; dividing by them once gave torques of 1e17 N m."""
    controller, robot = controller_for(name)
    rng = np.random.default_rng(5)
    for upper in (
        [["contact"], ["com", "base_orientation"]],
        [["friction", "torque_limits"], ["contact"], ["com", "base_orientation"]],
    ):
        for _ in range(10):
            q, v = disturbed_state(robot, rng)
            controller.set_stack(Stack.of(upper))
            without = controller.compute(q, v)
            controller.set_stack(Stack.of([*upper, ["posture"]]))
            with_posture = controller.compute(q, v)
            assert np.max(np.abs(with_posture.qdd - without.qdd)) <= LIMIT_TOL
            assert np.max(np.abs(with_posture.tau - without.tau)) <= LIMIT_TOL


@pytest.mark.parametrize("gait", ["stand", "trot", "height_step"])
def test_building_a_behaviour_leaves_the_shared_model_where_the_robot_is(gait: str) -> None:
    """Standing references are computed on a scratch model: the controller's model keeps the
    state of the last update, and the references are those of the standing posture."""
    controller, robot = controller_for("anymal")
    q, v = disturbed_state(robot, np.random.default_rng(7))
    model = controller.robot
    model.update(q, v)
    com, M = model.com.copy(), model.M.copy()
    behaviour = BEHAVIOURS[gait](model, robot.q_standing)
    np.testing.assert_array_equal(model.q, q)
    np.testing.assert_array_equal(model.v, v)
    np.testing.assert_array_equal(model.com, com)
    np.testing.assert_array_equal(model.M, M)
    standing = RobotModel(robot.model, robot.contacts)
    standing.update(robot.q_standing, np.zeros(robot.model.nv))
    assert behaviour.references.base_height == pytest.approx(robot.q_standing[2])
    if gait != "stand":  # stand keeps the robot's own x, y and heading
        np.testing.assert_allclose(behaviour.references.com, standing.com, atol=1e-12)


def test_a_behaviour_without_options_rejects_them_by_name() -> None:
    controller, robot = controller_for("anymal")
    stand = BEHAVIOURS["stand"](controller.robot, robot.q_standing)
    with pytest.raises(ValueError, match="gait 'stand' takes no step_height"):
        stand.configure(step_height=0.1)
    stand.configure()  # no options: nothing to reject


def test_each_task_declares_the_gains_it_reads() -> None:
    """A gain a task does not declare leaves its rows unchanged."""
    controller, robot = controller_for("anymal")
    q, v = disturbed_state(robot, np.random.default_rng(3))
    controller.robot.update(q, v)
    for name, task in controller.tasks.items():
        assert "weight" in task.GAINS, name
        before = task.rows(controller.robot, controller.references)
        before = before.A.copy(), before.b.copy()
        for gain in ("kp", "kd"):
            if gain not in task.GAINS:
                controller.set_gains(name, **{gain: 123.0})
        after = task.rows(controller.robot, controller.references)
        # (momentum's LQR gain blends over its first ticks: equal to rounding, not bitwise)
        np.testing.assert_allclose(after.A, before[0], rtol=1e-12, atol=1e-12, err_msg=name)
        np.testing.assert_allclose(after.b, before[1], rtol=1e-12, atol=1e-12, err_msg=name)
    assert controller.gains_used()["forces"] == ("weight",)
    assert controller.gains_used()["contact"] == ("kd", "weight")


@pytest.mark.parametrize("name", ROBOTS)
def test_the_com_drift_is_the_rate_of_the_com_velocity_at_zero_acceleration(name: str) -> None:
    """com_drift = J̇_com v, the CoM task's drift (its row is J_com q̈ = a_d − J̇_com v): the
    derivative of J_com(q) v along q̇ = v at constant v, by central differences. (Until
    2026-12-02 both kernels read data.acom after computeAllTerms, which leaves it at zero.)"""
    robot = build_robot(load_description(name))
    model = RobotModel(robot.model, robot.contacts)
    q, v = disturbed_state(robot, np.random.default_rng(3))
    v *= 10.0  # a drift well above the difference's error
    model.update(q, v)
    drift = model.com_drift.copy()
    step = 1e-6
    rates = []
    for sign in (1.0, -1.0):
        model.update(pin.integrate(robot.model, q, sign * step * v), v)
        rates.append(model.com_velocity.copy())
    finite_difference = (rates[0] - rates[1]) / (2.0 * step)
    assert np.linalg.norm(drift) > 0.1, drift  # m/s²: the check below has something to see
    np.testing.assert_allclose(drift, finite_difference, atol=1e-5 * (1.0 + np.linalg.norm(drift)))
