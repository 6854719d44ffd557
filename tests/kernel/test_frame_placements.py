"""The drawing state's frames (lab/robot.py FramePlacements): the native call and the Python
fallback place every drawn frame where pinocchio's updateFramePlacements does."""

import numpy as np
import pinocchio as pin
import pytest

from lab.description import load_description
from lab.robot import FramePlacements, _kernel, build_robot

native_only = pytest.mark.skipif(_kernel is None, reason="the native kernel is not built")
TOL = 1e-12


def _bent_state(robot, seed: int) -> np.ndarray:
    """The standing posture moved, turned and with every joint bent (radians)."""
    rng = np.random.default_rng(seed)
    q = robot.q_standing.copy()
    q[:3] += rng.uniform(-0.5, 0.5, 3)
    q[3:7] = pin.Quaternion(pin.exp3(rng.uniform(-1.0, 1.0, 3))).coeffs()
    q[7:] += rng.uniform(-0.4, 0.4, robot.model.nq - 7)
    return q


def _assert_at_pinocchio(robot, frames: FramePlacements, q: np.ndarray) -> None:
    data = robot.model.createData()
    pin.forwardKinematics(robot.model, data, q)
    pin.updateFramePlacements(robot.model, data)
    message = frames.message(q)
    assert message["names"] == list(frames.names)
    for frame, name, position, quaternion in zip(
        frames.ids, message["names"], message["positions"], message["quaternions"], strict=True
    ):
        expected = data.oMf[frame]
        assert np.allclose(position, expected.translation, rtol=0.0, atol=TOL), name
        rotation = pin.Quaternion(np.array(quaternion)).toRotationMatrix()
        assert np.allclose(rotation, expected.rotation, rtol=0.0, atol=TOL), name
        assert abs(np.linalg.norm(quaternion) - 1.0) < TOL, name


@pytest.mark.parametrize("name", ["anymal", "talos"])
@pytest.mark.parametrize("native", [pytest.param(True, marks=native_only), False])
def test_frames_sit_where_pinocchio_places_them(name, native) -> None:
    robot = build_robot(load_description(name))
    frames = FramePlacements(robot, native=native)
    assert frames.native is native
    for seed in range(3):
        _assert_at_pinocchio(robot, frames, _bent_state(robot, seed))


@native_only
@pytest.mark.parametrize("name", ["anymal", "talos"])
def test_the_python_fallback_gives_the_native_message(name) -> None:
    """Same names and positions; the same rotations (a quaternion and its negative are one)."""
    robot = build_robot(load_description(name))
    native, python = FramePlacements(robot, native=True), FramePlacements(robot, native=False)
    q = _bent_state(robot, 7)
    a, b = native.message(q), python.message(q)
    assert a["names"] == b["names"]
    assert np.allclose(a["positions"], b["positions"], rtol=0.0, atol=TOL)
    dots = np.abs(np.sum(np.array(a["quaternions"]) * np.array(b["quaternions"]), axis=1))
    assert np.allclose(dots, 1.0, rtol=0.0, atol=TOL)


@native_only
def test_a_wrong_configuration_raises_and_places_nothing() -> None:
    robot = build_robot(load_description("anymal"))
    frames = FramePlacements(robot, native=True)
    placements = frames.placements(robot.q_standing)
    before = placements.copy()
    with pytest.raises(ValueError, match=f"q needs {robot.model.nq} entries, got 5"):
        frames.placements(np.zeros(5))
    assert np.array_equal(placements, before)
