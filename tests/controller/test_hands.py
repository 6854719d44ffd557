"""The hands task (lab/controller/tasks/hands.py, cpp/tasks/hands.cpp): the same rows on both
kernels, a standing robot's hand reaching a target, and the `hand` command's validation."""

import numpy as np
import pinocchio as pin
import pytest

from lab.controller.hand_targets import HandTarget, HandTargets
from lab.controller.native import kernel_for, send_references
from lab.controller.tasks.base import TaskRows
from lab.controller.tasks.hands import heading, heading_rate
from lab.description import load_description
from lab.protocol.validation import CommandError, parse_command
from lab.world.session import Session, SessionConfig
from tests.helpers.controllers import controller_for
from tests.helpers.hands import HAND_STACK
from tests.helpers.kernel import assert_rows_equal, random_state

HANDED = ("talos_arms", "g1", "b1_z1")


def frames_of(name: str) -> tuple[str, ...]:
    return tuple(frame for _, frame in load_description(name).hands)


@pytest.mark.parametrize("name", HANDED)
def test_the_hands_rows_agree_between_kernels(name: str) -> None:
    _kernel = pytest.importorskip("lab._kernel", reason="the native kernel is not built")
    del _kernel
    controller, robot = controller_for(name)  # with the robot's hands, as a session has them
    kernel = kernel_for(controller)  # which mirrors them
    model, refs = controller.robot, controller.references
    rng = np.random.default_rng(29)
    frames = frames_of(name)
    h = len(frames)
    assert controller.hands == frames
    for i in range(6):
        # the robot's own joints options, then each hand on its arm by turns, then all of them
        joints = tuple(
            "arm" if (i >= 2 and (k + i) % 2 == 0) or i == 5 else "all" for k in range(h)
        )
        if i > 0:
            controller.set_hands(frames, joints)
            kernel.set_hands(list(frames), list(joints))
        q, v = random_state(robot, rng)
        model.update(q, v)
        kernel.update(q, v)
        kp, kd = rng.uniform(1.0, 400.0, 2)
        controller.set_gains("hands", kp, kd, 1.0)
        kernel.set_gains("hands", kp, kd, 1.0)
        refs.hand_position = rng.normal(0.0, 0.5, (h, 3))
        refs.hand_velocity = rng.normal(0.0, 0.5, (h, 3))
        refs.hand_acceleration = rng.normal(0.0, 0.5, (h, 3))
        refs.hand_rotation = np.array(
            [pin.rpy.rpyToMatrix(*rng.uniform(-3, 3, 3)) for _ in range(h)]
        )
        # world targets, then each hand's in the heading frame by turns, then all of them
        refs.hand_heading = np.array([(i > 0 and (k + i) % 3 == 0) or i == 3 for k in range(h)])
        send_references(kernel, refs)
        python = controller.tasks["hands"].rows(model, refs)
        assert python.A.shape == (6 * h, model.nx)
        assert_rows_equal(kernel.rows("hands"), python[:2], f"{name} state {i}: hands")


def test_a_heading_target_moves_with_the_trunk_and_leaves_its_linear_motion_alone() -> None:
    """A target in the heading frame has the same error wherever the robot stands and whichever
    way it faces (the base moved and turned about z, the joints as they were), and its position
    rows ask nothing of the base's linear acceleration (the hand is not to drag the trunk)."""
    controller, robot = controller_for("b1_z1")
    model, refs = controller.robot, controller.references
    rng = np.random.default_rng(13)
    q, v = random_state(robot, rng)
    refs.hand_position, refs.hand_rotation = np.array([[0.5, 0.0, 0.4]]), np.eye(3)[None]
    refs.hand_velocity, refs.hand_acceleration = np.zeros((1, 3)), np.zeros((1, 3))
    refs.hand_heading = np.array([True])
    task = controller.tasks["hands"]
    model.update(q, v)
    here = task.rows(model, refs)
    np.testing.assert_allclose(here.A[:3, :3], 0.0, atol=1e-12)
    moved = q.copy()
    moved[:3] += [3.0, -2.0, 0.1]
    turn = pin.rpy.rpyToMatrix(0.0, 0.0, 1.2)
    moved[3:7] = pin.Quaternion(turn @ pin.Quaternion(q[3:7]).matrix()).coeffs()
    model.update(moved, v)  # v in the base frame: the same motion, turned with the robot
    there = task.rows(model, refs)
    np.testing.assert_allclose(there.error[:3], turn @ here.error[:3], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(there.error[3:]), np.linalg.norm(here.error[3:]))


def test_an_arm_hand_s_rows_use_its_chain_from_the_trunk_only() -> None:
    """B1-Z1's hand with joints = "arm": its rows are the full Jacobian's on the Z1's six joints
    and zero on the base's and the legs' columns (the hand cannot push the trunk), and its error
    and right-hand side are those of the same hand with all joints."""
    controller, robot = controller_for("b1_z1")
    assert controller.hand_joints == ("all",)  # robots/b1_z1.toml
    controller.set_hands(frames_of("b1_z1"), ("arm",))
    model, refs = controller.robot, controller.references
    arm = [model.model.joints[model.model.getJointId(f"joint{i}")].idx_v for i in range(1, 7)]
    rng = np.random.default_rng(7)
    q, v = random_state(robot, rng)
    model.update(q, v)
    refs.hand_position, refs.hand_rotation = np.array([[0.5, 0.1, 0.9]]), np.eye(3)[None]
    refs.hand_velocity, refs.hand_acceleration = np.ones((1, 3)), np.zeros((1, 3))
    task = controller.tasks["hands"]
    mine = task.rows(model, refs)
    mine = TaskRows(mine.A.copy(), mine.b.copy(), mine.error.copy())
    controller.set_hands(frames_of("b1_z1"), ("all",))
    full = task.rows(model, refs)
    others = np.setdiff1d(np.arange(model.nx), arm)
    assert np.abs(full.A[:, :6]).max() > 0.1  # the base moves the hand in the world
    np.testing.assert_array_equal(mine.A[:, others], 0.0)
    np.testing.assert_array_equal(mine.A[:, arm], full.A[:, arm])
    np.testing.assert_array_equal(mine.b, full.b)
    np.testing.assert_array_equal(mine.error, full.error)


def test_a_bad_joints_option_is_refused_on_both_kernels_and_changes_nothing() -> None:
    controller, _ = controller_for("b1_z1")
    frames = frames_of("b1_z1")
    controller.set_hands(frames, ("arm",))
    with pytest.raises(ValueError, match="hand joints must be 'all' or 'arm', got 'legs'"):
        controller.set_hands(frames, ("legs",))
    with pytest.raises(ValueError, match="2 hand joints options for 1 hands"):
        controller.set_hands(frames, ("arm", "arm"))
    assert controller.hand_joints == ("arm",)
    _kernel = pytest.importorskip("lab._kernel", reason="the native kernel is not built")
    del _kernel
    kernel = kernel_for(controller)
    with pytest.raises(ValueError, match="hand joints must be 'all' or 'arm', got 'legs'"):
        kernel.set_hands(list(frames), ["legs"])
    with pytest.raises(ValueError, match="2 hand joints options for 1 hands"):
        kernel.set_hands(list(frames), ["arm", "arm"])


def test_the_heading_rate_is_the_yaw_s_derivative() -> None:
    """ψ̇ of the trunk's heading, against a finite difference of the yaw under a rotation at a
    random angular velocity (roll and pitch up to 0.4 rad, where ψ̇ ≠ ω_z)."""
    rng = np.random.default_rng(3)
    dt = 1e-6
    for _ in range(5):
        R = pin.rpy.rpyToMatrix(*rng.uniform(-0.4, 0.4, 2), rng.uniform(-3, 3))
        omega = rng.normal(0.0, 1.0, 3)
        later = pin.exp3(omega * dt) @ R
        yaw = pin.log3(heading(later) @ heading(R).T)[2] / dt
        assert heading_rate(R, omega) == pytest.approx(yaw, abs=1e-5)


def test_a_frame_the_model_lacks_is_refused_on_both_kernels_and_changes_nothing() -> None:
    controller, _ = controller_for("talos_arms")
    with pytest.raises(ValueError, match="no frame 'nope'"):
        controller.set_hands(("nope",))
    assert len(controller.tasks["hands"].frame_ids) == 2
    _kernel = pytest.importorskip("lab._kernel", reason="the native kernel is not built")
    del _kernel
    kernel = kernel_for(controller)
    with pytest.raises(ValueError, match="no frame 'nope'"):
        kernel.set_hands(["nope"])


def test_without_targets_the_task_gives_no_rows() -> None:
    controller, _ = controller_for("g1")
    rows = controller.tasks["hands"].rows(controller.robot, controller.references)
    assert rows.A.shape == (0, controller.robot.nx)


def test_references_with_another_number_of_hands_are_refused_on_both_kernels() -> None:
    controller, _ = controller_for("g1")  # two hands
    refs = controller.references
    refs.hand_position, refs.hand_velocity = np.zeros((1, 3)), np.zeros((1, 3))
    refs.hand_acceleration, refs.hand_rotation = np.zeros((1, 3)), np.eye(3)[None]
    with pytest.raises(ValueError, match="hand_position has 1 rows, expected 0 or 2"):
        controller.tasks["hands"].rows(controller.robot, refs)
    _kernel = pytest.importorskip("lab._kernel", reason="the native kernel is not built")
    del _kernel
    with pytest.raises(ValueError, match="hand_position"):
        send_references(kernel_for(controller), refs)


def test_a_circle_target_moves_on_its_circle_with_its_derivatives() -> None:
    target = HandTarget(np.zeros(3), np.eye(3), radius=0.1, period=2.0, axis=np.array([0, 0, 1.0]))
    dt = 1e-5
    for t in (0.0, 0.3, 1.1):
        p, v, a = target.at(t)
        assert np.linalg.norm(p) == pytest.approx(0.1) and abs(p[2]) < 1e-12
        np.testing.assert_allclose(
            v, (target.at(t + dt)[0] - target.at(t - dt)[0]) / (2 * dt), atol=1e-6
        )
        np.testing.assert_allclose(
            a, (target.at(t + dt)[1] - target.at(t - dt)[1]) / (2 * dt), atol=1e-4
        )
    # counter-clockwise about +z
    p0, v0, _ = target.at(0.0)
    assert np.cross(p0, v0)[2] > 0


@pytest.mark.parametrize(
    ("payload", "message"),
    [
        ({"name": "left", "position": [0.1, float("nan"), 1.0]}, "position\\[1\\]' must be finite"),
        ({"name": "left", "position": [0.1, 0.0]}, "'position' must be a list of 3 numbers"),
        ({"name": "left"}, "'position' is missing"),
        (
            {"name": "left", "position": [0, 0, 1], "radius": -0.1},
            "'radius' = -0.1 is out of range",
        ),
        ({"name": "left", "position": [0, 0, 1], "period": 0}, "'period' = 0 is out of range"),
        ({"name": "left", "position": [0, 0, 1], "axis": [0, 0, 0]}, "'axis' must not be zero"),
        ({"name": "left", "position": [0, 0, 1], "rpy": [0, 0, float("inf")]}, "must be finite"),
        ({"name": "left", "position": [0, 0, 1], "speed": 1}, "unknown field"),
    ],
)
def test_the_hand_command_refuses_bad_payloads_naming_the_field(payload, message) -> None:
    with pytest.raises(CommandError, match=message):
        parse_command("hand", payload)


def test_a_hand_command_sets_the_target_and_a_bad_hand_changes_nothing() -> None:
    session = Session(SessionConfig(robot="talos_arms", stack=HAND_STACK))
    before = session.info()["hands"]
    assert [h["name"] for h in before] == ["left", "right"]
    reply = session.handle("hand", {"name": "nope", "position": [0.0, 0.0, 1.0]})
    assert not reply["ok"] and "unknown hand 'nope' (hands: left, right)" in reply["error"]
    assert session.info()["hands"] == before
    far = [50.0, 0.0, 1.0]  # out of reach but finite: accepted
    reply = session.handle("hand", {"name": "left", "position": far, "rpy": [0.0, 0.0, 0.5]})
    assert reply["ok"] and reply["hand"]["position"] == far
    assert reply["hand"]["rpy"] == pytest.approx([0.0, 0.0, 0.5])
    assert session.info()["hands"][1] == before[1]


def hand_position(session: Session, frame: str) -> np.ndarray:
    return session.model.frame_position(frame)


def test_a_standing_talos_reaches_a_target_10_cm_away_with_its_feet_forces_in_their_cones() -> None:
    """The left hand's target 10 cm forward and up-left of where it stands: within 1 cm after
    0.5 s (issue 29), the measured sole forces inside the friction cone all along, the robot
    standing."""
    session = Session(SessionConfig(robot="talos_arms", stack=HAND_STACK))
    frame = frames_of("talos_arms")[0]
    start = session.info()["hands"][0]
    goal = np.array(start["position"]) + np.array([0.08, 0.03, 0.05])  # |offset| = 9.9 cm
    assert np.linalg.norm(goal - start["position"]) == pytest.approx(0.099, abs=1e-3)
    assert session.handle("hand", {"name": "left", "position": goal.tolist()})["ok"]
    mu = load_description("talos_arms").friction
    worst_cone = 0.0
    for _ in range(500):
        session.tick()
        f = session.plant.foot_forces()
        tangential = np.linalg.norm(f[:, :2], axis=1)
        worst_cone = max(worst_cone, float(np.max(tangential - mu * f[:, 2])))
    error = np.linalg.norm(hand_position(session, frame) - goal)
    assert not session.fell
    assert error < 0.01, f"hand {error * 100:.2f} cm from its target after 0.5 s"
    assert worst_cone <= 1e-6, f"a sole force left its friction cone by {worst_cone:.3g} N"
    assert all(f[2] > 0 for f in session.plant.foot_forces())


def test_hand_targets_hold_each_hand_where_it_stands() -> None:
    description = load_description("g1")
    controller, robot = controller_for("g1")
    targets = HandTargets.holding(robot.model, robot.q_standing, description.hands)
    refs = controller.references
    targets.write(refs, 0.0)
    controller.robot.update(robot.q_standing, np.zeros(robot.model.nv))
    error = controller.tasks["hands"].rows(controller.robot, refs).error
    np.testing.assert_allclose(error, 0.0, atol=1e-12)


def test_a_target_set_after_a_write_reaches_the_references_at_the_next_write() -> None:
    """Still targets are written once per references object; a new target (or a moving one)
    is written again."""
    controller, robot = controller_for("g1")
    targets = HandTargets.holding(robot.model, robot.q_standing, load_description("g1").hands)
    refs = controller.references
    targets.write(refs, 0.0)
    still = targets.target("left")
    moved = HandTarget(still.position + 0.1, still.rotation)
    targets.set("left", moved)
    targets.write(refs, 0.1)
    np.testing.assert_allclose(refs.hand_position[0], moved.position)
    circling = HandTarget(still.position, still.rotation, radius=0.05, period=1.0, start=0.0)
    targets.set("left", circling)
    for t in (0.25, 0.5):
        targets.write(refs, t)
        np.testing.assert_allclose(refs.hand_position[0], circling.at(t)[0])
