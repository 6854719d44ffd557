"""The upper body on one sole: the `upper_body` task (the joints that move no contact) and the
free-arm robots' stance stack, Table 4 with that task in a level above the momentum."""

import numpy as np
import pytest

from lab.controller.behaviours.stance import LIFT_HEIGHT, LIFT_S, SHIFT_S, UNLOAD_S
from lab.controller.model import BASE_DOF
from lab.description import ROBOTS_DIR, load_description, read_description
from lab.world.session import Session, SessionConfig
from tests.helpers.controllers import controller_for
from tests.helpers.kernel import random_state

# The joints a sole does not move, by the name's start: the torso (waist) and the arms.
UPPER_BODY = {
    "talos": ("torso_",),
    "talos_arms": ("torso_", "arm_"),
    "g1": (
        "waist_",
        "left_shoulder",
        "right_shoulder",
        "left_elbow",
        "right_elbow",
        "left_wrist",
        "right_wrist",
    ),
    "anymal": (),
}


@pytest.mark.parametrize("name", sorted(UPPER_BODY))
def test_the_upper_body_rows_are_the_joints_no_sole_moves(name: str) -> None:
    """One row per joint outside the legs, named as the robot names its torso and arms, each
    asking q̈_j = kp (q_ref − q_j) − kd q̇_j: a quadruped without an arm has none."""
    controller, robot = controller_for(name)
    model = controller.robot
    q, v = random_state(robot, np.random.default_rng(3))
    model.update(q, v)
    controller.set_gains("upper_body", 100.0, 20.0, 1.0)
    A, b, error = controller.tasks["upper_body"].rows(model, controller.references)
    names = list(robot.model.names[2:])  # the actuated joints, after universe and root
    joints = [j for j in range(model.na) if names[j].startswith(UPPER_BODY[name])]
    assert A.shape == (len(joints), model.nx) and (len(joints) > 0) == bool(UPPER_BODY[name])
    expected = np.zeros_like(A)
    expected[np.arange(len(joints)), BASE_DOF + np.array(joints, dtype=int)] = 1.0
    np.testing.assert_array_equal(A, expected)
    e = controller.references.posture[joints] - model.joint_positions[joints]
    np.testing.assert_allclose(error, e, atol=1e-15)
    np.testing.assert_allclose(b, 100.0 * e - 20.0 * model.joint_velocities[joints], atol=1e-12)


def test_the_free_arm_robots_have_their_own_stance_stack_and_talos_keeps_table4() -> None:
    """`stance_stack` in robots/*.toml: the free-arm robots' `stance` brings herzog_table4_arms,
    the arms-locked Talos Herzog's herzog_table4."""
    assert load_description("talos").stance_stack == "herzog_table4"
    for name in ("talos_arms", "g1"):
        assert load_description(name).stance_stack == "herzog_table4_arms"


def test_a_stance_stack_that_is_no_preset_is_refused_naming_it(tmp_path) -> None:
    path = tmp_path / "talos_arms.toml"
    text = (ROBOTS_DIR / "talos_arms.toml").read_text()
    path.write_text(text.replace('stance_stack = "herzog_table4_arms"', 'stance_stack = "table5"'))
    with pytest.raises(ValueError, match=r"stance_stack 'table5' is no stack preset"):
        read_description(path)


@pytest.mark.parametrize("name", ["talos_arms", "g1"])
def test_free_arms_hold_their_posture_while_the_robot_lifts_a_sole_and_stands_a_push(
    name: str,
) -> None:
    """`stance left` with the LQR law (Herzog §5.4) on a robot with free arms: the right sole
    lifts 10 cm (within 2.5 cm) and the left carries the weight (within 5 %) while the torso and
    arms stay within 0.05 rad of their posture (measured 0.001 and 0.007 rad; under
    herzog_table4, where they share the posture weight 0.1 with the legs beside the momentum,
    Talos raised its left arm 2.71 rad and G1 its waist roll 0.52 rad, to its limit); then a
    side push of 5 % of the weight for 0.1 s is stood, the CoG within 3 cm of the sole."""
    session = Session(SessionConfig(robot=name))
    assert session.handle("momentum", {"mode": "lqr"})["ok"]
    reply = session.handle("stance", {"side": "left"})
    assert reply["ok"] and reply["preset"] == "herzog_table4_arms"
    upper = np.flatnonzero(
        session.controller.tasks["upper_body"]
        .rows(session.model, session.controller.references)
        .A[:, BASE_DOF:]
        .any(axis=0)
    )
    start = session.model.joint_positions[upper].copy()
    farthest = 0.0
    for _ in range(round(1000 * (SHIFT_S + UNLOAD_S + LIFT_S + 0.5))):
        session.tick()
        moved = np.abs(session.model.joint_positions[upper] - start).max()
        farthest = max(farthest, float(moved))
    assert not session.fell and session.qp_failures == 0
    assert abs(float(session.model.contact_positions[1, 2]) - LIFT_HEIGHT) < 0.025
    weight = session.model.mass * 9.81
    assert session.plant.foot_forces()[0, 2] == pytest.approx(weight, rel=0.05)
    assert farthest < 0.05
    push = {"body": session.robot.base_link, "force": [0.0, 0.05 * weight, 0.0], "duration": 0.1}
    assert session.handle("push", push)["ok"]
    for _ in range(1000):
        session.tick()
    assert not session.fell and session.qp_failures == 0
    sole = session.model.contact_positions[0, :2]
    assert np.linalg.norm(session.model.com[:2] - sole) < 0.03
