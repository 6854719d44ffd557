"""WBOSC (Kim 2016 App. A): the contact-consistent maps checked against pinocchio, the internal
force manifold, the closed-form method on Bolt, and Bolt standing under it in MuJoCo."""

import numpy as np
import pinocchio as pin
import pytest

from lab.controller.behaviours.balance import standing_references
from lab.controller.contact_dynamics import contact_dynamics
from lab.controller.controller import ControllerConfig, WholeBodyController
from lab.controller.hierarchy.wbosc import WboscStackError
from lab.controller.internal_force import internal_force_map, internal_forces
from lab.controller.model import RobotModel
from lab.controller.references import WalkReferences
from lab.controller.stack import Stack
from lab.description import load_description
from lab.robot import build_robot
from lab.world.session import Session, SessionConfig
from tests.helpers.wbosc import BOLT_STACK


@pytest.fixture(scope="module")
def bolt() -> tuple[RobotModel, np.ndarray]:
    robot = build_robot(load_description("bolt"))
    return RobotModel(robot.model, robot.contacts), robot.q_standing


def bolt_controller(bolt, stack=BOLT_STACK) -> WholeBodyController:
    model, q = bolt
    desc = load_description("bolt")
    config = ControllerConfig(Stack.of(stack), dict(desc.gains), method="wbosc")
    refs = standing_references(model, q)
    return WholeBodyController(model, refs, config, np.full(model.na, 2.7))


@pytest.mark.parametrize("n", [2, 3, 4])
def test_internal_forces_make_no_net_wrench(n: int) -> None:
    """Forces along W_intᵀ (any internal force) sum to zero force and zero moment."""
    rng = np.random.default_rng(n)
    positions = rng.uniform(-0.5, 0.5, (n, 3))
    W = internal_force_map(positions)
    assert W.shape == (n * (n - 1) // 2, 3 * n)
    for tension in rng.standard_normal((5, len(W))):
        forces = (W.T @ tension).reshape(n, 3)
        assert np.allclose(forces.sum(axis=0), 0.0, atol=1e-12)
        moment = sum(np.cross(p, f) for p, f in zip(positions, forces, strict=True))
        assert np.allclose(moment, 0.0, atol=1e-12)
    # Two feet pushing apart with 5 N each: F_int = x̂ᵀ(λ_b − λ_a) = 10 N (eq. 14–17).
    feet = np.array([[0.0, 0.1, 0.0], [0.0, -0.1, 0.0]])
    on_robot = np.array([[0.0, -5.0, 6.0], [0.0, 5.0, 6.0]])  # the ground pushes them in
    assert internal_forces(feet, on_robot) == pytest.approx([10.0])


def test_contact_consistent_torques_keep_the_feet_still(bolt) -> None:
    """Any torque through eqs. 28–30: pinocchio finds the feet not accelerating and the
    equations of motion holding with the reaction forces of eq. 29."""
    model, q = bolt
    rng = np.random.default_rng(0)
    v = 0.3 * rng.standard_normal(model.nv)
    model.update(q, v)
    dyn = contact_dynamics(model.M, model.h, model.Jc, model.Jc_dot_v)
    for tau in rng.standard_normal((4, model.na)):
        qdd = dyn.qdd_of_torque @ tau + dyn.qdd_free
        forces = dyn.force_of_torque @ tau + dyn.force_free
        data = model.model.createData()
        pin.forwardKinematics(model.model, data, q, v, qdd)
        for fid in model.frame_ids:
            acc = pin.getFrameClassicalAcceleration(model.model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            assert np.linalg.norm(acc.linear) < 1e-9
        generalized = pin.rnea(model.model, data, q, v, qdd) - model.Jc.T @ forces
        assert np.allclose(generalized, np.r_[np.zeros(6), tau], atol=1e-9)
        # Torques in the null space of Φ* change the internal force and nothing else (eq. 37).
        tau_int = dyn.internal_basis[:, 0]
        assert np.allclose(dyn.qdd_of_torque @ tau_int, 0.0, atol=1e-9)
        change = internal_forces(
            model.contact_positions, (dyn.force_of_torque @ tau_int).reshape(2, 3)
        )
        assert abs(change[0]) > 1.0


def test_a_wbosc_tick_realizes_the_internal_force_and_the_first_task(bolt) -> None:
    """On Bolt standing: x is consistent (feet still), W_int λ equals the command of eq. 12
    exactly and the CoM task (the first motion level) is met exactly."""
    controller = bolt_controller(bolt)
    controller.internal_force.reference = 5.0
    model, q = bolt
    controller.update(q, np.zeros(model.nv))
    out = controller.solve()
    assert out.solution.status == "ok"
    force = internal_forces(model.contact_positions, out.forces.reshape(2, 3))
    assert force == pytest.approx([5.0], abs=1e-9)  # no sensing yet: the command is the ref
    assert out.solution.residuals[2] < 1e-9  # com
    assert np.linalg.norm(model.Jc @ out.qdd + model.Jc_dot_v) < 1e-9
    # A push of 100 N on flat ground with μ = 0.8 and 6 N of weight per foot: reported.
    controller.internal_force.reference = 100.0
    out = controller.solve()
    assert out.solution.status == "violated"
    assert any("friction" in line for line in out.solution.violations)


def test_wbosc_and_cascade_agree_where_every_level_is_met(bolt) -> None:
    """On Bolt's stack each level is either met exactly or left without freedom, so the metric
    of the least squares does not matter: strict priorities give the same torques either way."""
    controller = bolt_controller(bolt)
    controller.internal_force.reference = 3.0
    model, q = bolt
    controller.references.com[:] += [0.004, 0.0, -0.005]  # ask some motion, within the limits
    controller.update(q, np.zeros(model.nv))
    wbosc = controller.solve()
    controller.set_hierarchy("cascade")
    cascade = controller.solve()
    assert set(cascade.solution.levels) == {"exact"}  # no inequality binds
    assert np.allclose(wbosc.tau, cascade.tau, atol=1e-6)
    assert np.allclose(wbosc.forces, cascade.forces, atol=1e-6)


def test_wbosc_refuses_a_task_it_cannot_realize_and_changes_nothing(bolt) -> None:
    controller = bolt_controller(bolt)
    with pytest.raises(WboscStackError, match="torques"):
        controller.set_stack(Stack.of([*BOLT_STACK, ["torques"]]))
    assert controller.config.stack == Stack.of(BOLT_STACK)
    controller.set_hierarchy("cascade")
    controller.set_stack(Stack.of([*BOLT_STACK, ["torques"]]))
    with pytest.raises(ValueError, match="torques"):
        controller.set_hierarchy("wbosc")
    assert controller.config.method == "cascade"


def run(session: Session, seconds: float) -> None:
    for _ in range(round(seconds / 1e-3)):
        session.tick()


def test_bolt_stands_under_wbosc_and_holds_the_internal_force() -> None:
    """2 s on flat ground with a 2 N internal force (K_F = 1, sensed from the contact forces):
    no fall, and the measured internal force within 0.1 N of the reference (0.044 N measured;
    docs/replications.md, Kim 2016)."""
    session = Session(SessionConfig(robot="bolt", method="wbosc", stack=BOLT_STACK))
    controller = session.controller
    controller.internal_force.reference = 2.0
    controller.set_gains("internal_force", kp=1.0)
    run(session, 1.0)
    errors = []
    for _ in range(1000):
        session.tick()
        measured = internal_forces(session.model.contact_positions, session.plant.foot_forces())
        errors.append(measured[0] - 2.0)
    assert not session.fell
    assert abs(np.mean(errors)) < 0.1
    assert session.telemetry()["status"]["status"] == "ok"


def test_bolt_switches_live_between_cascade_and_wbosc() -> None:
    session = Session(SessionConfig(robot="bolt", method="cascade"))
    run(session, 0.5)
    assert session.handle("hierarchy", {"method": "wbosc"})["ok"]
    run(session, 1.0)
    assert session.handle("hierarchy", {"method": "cascade"})["ok"]
    run(session, 0.5)
    assert not session.fell


def test_the_internal_force_command_and_telemetry() -> None:
    session = Session(SessionConfig(robot="bolt", method="wbosc"))
    reply = session.handle("internal_force", {"reference": 4.0, "source": "torques"})
    assert reply["ok"] and reply["internal_force"]["reference"] == 4.0
    assert not session.handle("internal_force", {"source": "strain gauges"})["ok"]
    assert session.controller.internal_force.source == "torques"  # the rejection changed nothing
    run(session, 0.05)
    report = session.telemetry()["internal_force"]
    assert report["source"] == "torques" and len(report["sensed"]) == 1
    # Sensed from the torques (eq. 13) the internal force is the one commanded a tick before.
    assert report["sensed"][0] == pytest.approx(4.0, abs=0.2)


def test_a_contact_transition_ramps_the_dual_contact_force(bolt) -> None:
    """Kim §III-F: a foot being unloaded leaves the contact set and carries w times the force
    it had in dual contact (eqs. 9–10); the other foot stays still and the dynamics hold."""
    controller = bolt_controller(bolt)
    model, q = bolt
    base = controller.references
    controller.references = WalkReferences(**vars(base), force_weight=np.array([np.nan, 1.0]))
    controller.update(q, np.zeros(model.nv))
    dual = solve_wbosc_without_transition(controller)
    right = slice(3, 6)
    for w in (1.0, 0.6, 0.0):
        controller.references.force_weight[1] = w
        out = controller.solve()
        assert np.allclose(out.forces[right], w * dual.forces[right], atol=1e-9)
        assert np.linalg.norm(model.Jc[:3] @ out.qdd + model.Jc_dot_v[:3]) < 1e-9
        generalized = model.M @ out.qdd + model.h - model.Jc.T @ out.forces
        assert np.allclose(generalized, np.r_[np.zeros(6), out.tau], atol=1e-9)
        if w == 1.0:  # the dual contact's forces: its torques too, no jump (eq. 9's aim)
            assert np.linalg.norm(out.tau - dual.tau) < 1e-6 * np.linalg.norm(dual.tau)


def solve_wbosc_without_transition(controller: WholeBodyController):
    weights = controller.references.force_weight.copy()
    controller.references.force_weight[:] = np.nan
    out = controller.solve()
    controller.references.force_weight[:] = weights
    return out
