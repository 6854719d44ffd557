"""Robot descriptions load, and the standing posture, limits and feet are physically right."""

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest

from lab.controller.behaviours.footholds import FOOTHOLD_PLANNERS
from lab.description import ROBOT_NAMES, ROBOTS_DIR, load_description, read_description
from lab.robot import build_robot

HEIGHT_TOL = 1e-9  # m: the base height is solved so the lowest contact is at z = 0 exactly
SOLE_TILT_TOL = 0.01  # rad: Talos' reference posture tilts the ankles by 1.7 mrad


@pytest.fixture(scope="module", params=ROBOT_NAMES)
def robot(request):
    return build_robot(load_description(request.param))


def test_the_papers_robots_and_the_unitree_robots_are_described() -> None:
    papers = {"anymal", "hyq", "solo12", "talos", "bolt"}
    assert set(ROBOT_NAMES) == papers | {"talos_arms", "go2", "a1", "b1", "b1_z1", "g1"}


def test_every_default_foothold_planner_exists() -> None:
    for name in ROBOT_NAMES:
        footholds = load_description(name).footholds
        assert footholds is None or footholds in FOOTHOLD_PLANNERS, name


def test_unknown_robot_names_the_known_ones() -> None:
    with pytest.raises(KeyError) as error:
        load_description("asimo")
    assert "asimo" in str(error.value)
    assert all(name in str(error.value) for name in ROBOT_NAMES)


def test_model_sizes_and_torque_limits(robot) -> None:
    model = robot.model
    assert model.joints[1].shortname() == "JointModelFreeFlyer"
    assert robot.torque_limits.shape == (model.nv - 6,)
    assert np.all(np.isfinite(robot.torque_limits)) and np.all(robot.torque_limits > 0.0)
    assert len(robot.joint_names) == model.nv - 6
    # Physical limits sit strictly above the contacts (docs/controller.md, The stack).
    limits, contacts = robot.description.stack[0], robot.description.stack[1]
    assert {"friction", "torque_limits"} <= set(limits) and contacts == ("contact",)
    assert ("cop" in limits) == any(c.kind == "flat" for c in robot.contacts)


def test_standing_posture_puts_every_contact_on_the_ground(robot) -> None:
    model, data = robot.model, robot.model.createData()
    q = robot.q_standing
    np.testing.assert_array_equal(q[3:7], [0.0, 0.0, 0.0, 1.0])
    assert np.all(q[7:] >= model.lowerPositionLimit[7:])
    assert np.all(q[7:] <= model.upperPositionLimit[7:])
    pin.framesForwardKinematics(model, data, q)
    for contact in robot.contacts:
        placement = data.oMf[model.getFrameId(contact.frame)]
        expected = contact.radius if contact.kind == "point" else 0.0
        assert abs(placement.translation[2] - expected) < HEIGHT_TOL, contact.name
        if contact.kind == "flat":
            tilt = np.arccos(np.clip(placement.rotation[2, 2], -1.0, 1.0))
            assert tilt < SOLE_TILT_TOL, contact.name


def test_point_feet_match_the_urdf_collision_sphere(robot) -> None:
    """Where the URDF models the foot as a sphere, the contact is its centre and radius."""
    links = {link.get("name"): link for link in ET.parse(robot.description.urdf_path).getroot()}
    for contact, link, offset in zip(
        robot.contacts, robot.foot_links, robot.foot_offsets, strict=True
    ):
        if contact.kind != "point":
            continue  # a flat sole stands for the link's collision shapes as a whole
        for collision in links[link].findall("collision"):
            sphere = collision.find("geometry/sphere")
            if sphere is None:
                continue
            origin = collision.find("origin").get("xyz").split()
            np.testing.assert_allclose(offset, [float(x) for x in origin], atol=1e-12)
            assert contact.radius == float(sphere.get("radius"))


def test_locked_joints_are_welded_at_the_reference_posture() -> None:
    """Talos' locked arms sit where the full model puts them at the SRDF posture."""
    robot = build_robot(load_description("talos"))
    desc = robot.description
    full = pin.buildModelFromUrdf(str(desc.urdf_path), pin.JointModelFreeFlyer())
    pin.loadReferenceConfigurations(full, str(desc.srdf_path), False)
    q_full = full.referenceConfigurations[desc.posture].copy()
    q_full[:7] = robot.q_standing[:7]
    assert robot.model.nv == full.nv - len(desc.locked_joints)
    assert not any(robot.model.existJointName(j) for j in desc.locked_joints)
    data, data_full = robot.model.createData(), full.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_standing)
    pin.framesForwardKinematics(full, data_full, q_full)
    for link in ("gripper_left_base_link", "arm_right_7_link", "head_2_link"):
        reduced = data.oMf[robot.model.getFrameId(link)]
        original = data_full.oMf[full.getFrameId(link)]
        assert np.allclose(reduced.homogeneous, original.homogeneous, atol=1e-12), link


def b1_z1_with_hand(tmp_path, entry: str):
    """robots/b1_z1.toml copied into tmp_path with its hand `arm = <entry>`."""
    text = (ROBOTS_DIR / "b1_z1.toml").read_text()
    start = text.index("[hands]")
    end = text.index("\n\n", start)
    path = tmp_path / "b1_z1.toml"
    path.write_text(text[:start] + f"[hands]\narm = {entry}" + text[end:])
    return path


@pytest.mark.parametrize(
    ("entry", "joints"),
    [('"gripperStator"', "all"), ('{ frame = "gripperStator", joints = "arm" }', "arm")],
)
def test_a_hand_is_a_frame_name_or_a_table_with_its_joints(tmp_path, entry, joints) -> None:
    description = read_description(b1_z1_with_hand(tmp_path, entry))
    assert description.hands == (("arm", "gripperStator"),)
    assert description.hand_joints == (joints,)


@pytest.mark.parametrize(
    "entry", ['{ frame = "gripperStator", joints = "legs" }', '{ link = "gripperStator" }', "3"]
)
def test_a_bad_hand_entry_names_the_hand_and_the_forms(tmp_path, entry) -> None:
    path = b1_z1_with_hand(tmp_path, entry)
    with pytest.raises(ValueError, match="robot 'b1_z1': \\[hands\\] 'arm' must be a frame name"):
        read_description(path)
