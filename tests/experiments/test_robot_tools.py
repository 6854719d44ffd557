"""`lab robot new` guesses a robot's feet from its URDF; `lab robot check` says what fails."""

import dataclasses
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest

from lab.description import load_description, read_description
from lab.experiments.robot_check import _check_rest, check_robot
from lab.experiments.robot_new import guess_feet, new_robot, resolve_urdf
from lab.robot import build_robot


def test_new_robot_finds_the_four_point_feet_of_a_quadruped(tmp_path) -> None:
    path = new_robot("go1", "go1", directory=tmp_path, settle=False)
    robot = build_robot(read_description(path))
    assert [c.kind for c in robot.contacts] == ["point"] * 4
    assert {c.frame for c in robot.contacts} == {
        f"{leg}_foot_contact" for leg in ("FL", "FR", "RL", "RR")
    }
    # The URDF's foot collision is a 2 cm ball at the foot link's origin.
    assert all(c.radius == pytest.approx(0.02) for c in robot.contacts)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, robot.q_standing)
    heights = [data.oMf[robot.model.getFrameId(c.frame)].translation[2] for c in robot.contacts]
    np.testing.assert_allclose(heights, 0.02, atol=1e-9)  # every ball on the floor


def test_new_robot_makes_flat_soles_of_a_humanoids_contact_spheres() -> None:
    urdf, srdf = resolve_urdf(str(load_description("g1").urdf_path))
    assert srdf is None  # G1 ships none: the neutral posture
    feet = guess_feet(urdf)
    assert [f.link for f in feet] == ["left_ankle_roll_link", "right_ankle_roll_link"]
    for foot in feet:
        # Four 5 mm balls at x in {-0.05, 0.12}, y = ±0.025/±0.03, z = -0.03: their rectangle.
        assert foot.kind == "flat"
        assert foot.half_length == pytest.approx(0.09)
        assert foot.half_width == pytest.approx(0.035)
        np.testing.assert_allclose(foot.offset, [0.035, 0.0, -0.035], atol=1e-12)


def test_new_robot_refuses_a_bad_name_and_an_unknown_source(tmp_path) -> None:
    with pytest.raises(ValueError, match="lower-case"):
        new_robot("Go 1", "go1", directory=tmp_path, settle=False)
    with pytest.raises(FileNotFoundError, match=r"neither a \.urdf file"):
        new_robot("x", "no_such_robot", directory=tmp_path, settle=False)
    assert not list(tmp_path.iterdir())


def test_check_passes_a_shipped_robot() -> None:
    findings = check_robot("go2", stand_seconds=1.0)
    assert [f.check for f in findings] == ["load", "engines", "rest", "stand"]
    assert all(f.ok for f in findings), findings


def test_check_names_a_foot_left_out_of_the_description() -> None:
    desc = load_description("go2")
    three_feet = dataclasses.replace(desc, contacts=desc.contacts[:3])
    finding = _check_rest(build_robot(three_feet))
    # The fourth foot's own collision shape stays and touches the floor: not a declared foot.
    assert not finding.ok and "other than a foot touches the ground" in finding.message


def test_lab_robot_check_names_an_unknown_robot() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "lab", "robot", "check", "asimo"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 1
    assert "FAIL load" in result.stdout and "asimo" in result.stdout
