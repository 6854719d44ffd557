"""Pure logic of the browser lab: stack edits, joystick mapping, colours, drag spring, buffers."""

import math

import numpy as np
import pytest

from lab.ui import stack_edit as se
from lab.ui.colors import friction_usage, usage_colour
from lab.ui.drag_push import Spring, spring_force
from lab.ui.gaits import gait_options
from lab.ui.joystick import JoystickLimits, VelocityCommand, from_offset, tap
from lab.ui.ownership import ControlOwnership
from lab.ui.plot_buffer import RollingBuffer

STACK = [["contacts"], ["base_orientation", "com"], ["posture"]]


def test_move_to_level_above_and_below():
    assert se.move_to_level_above(STACK, "com") == [
        ["contacts", "com"],
        ["base_orientation"],
        ["posture"],
    ]
    assert se.move_to_level_below(STACK, "com") == [
        ["contacts"],
        ["base_orientation"],
        ["posture", "com"],
    ]
    # a task alone in its level: the level disappears
    assert se.move_to_level_above(STACK, "posture") == [
        ["contacts"],
        ["base_orientation", "com", "posture"],
    ]
    # at the ends a new level is made
    assert se.move_to_level_above(STACK, "contacts") == STACK
    assert se.move_to_level_below(STACK, "posture") == STACK
    assert se.move_to_level_above(STACK, "base_orientation")[0] == ["contacts", "base_orientation"]


def test_new_level_within_level_and_enable_disable():
    assert se.move_to_new_level(STACK, "com", above=True) == [
        ["contacts"],
        ["com"],
        ["base_orientation"],
        ["posture"],
    ]
    assert se.move_to_new_level(STACK, "com", above=False)[2] == ["com"]
    assert se.move_within_level(STACK, "com", -1)[1] == ["com", "base_orientation"]
    assert se.move_within_level(STACK, "com", +5)[1] == ["base_orientation", "com"]
    off = se.disable_task(STACK, "posture")
    assert off == [["contacts"], ["base_orientation", "com"]]
    assert se.enable_task(off, "posture", 2) == STACK
    assert se.enable_task(off, "posture", 0)[0] == ["contacts", "posture"]
    assert STACK == [["contacts"], ["base_orientation", "com"], ["posture"]]  # input untouched
    with pytest.raises(ValueError, match="'nope'"):
        se.move_to_level_above(STACK, "nope")
    with pytest.raises(ValueError, match="already"):
        se.enable_task(STACK, "com", 0)


def test_joystick_offset_mapping():
    lim = JoystickLimits(max_vx=0.6, max_vy=0.4, radius=0.3, deadzone=0.02)
    assert from_offset(0.015, -0.01, 0.0, lim) == VelocityCommand(0.0, 0.0, 0.0)
    full = from_offset(0.5, 0.0, 0.0, lim)
    assert full.vx == pytest.approx(0.6) and full.vy == 0.0
    half = from_offset(0.0, -0.16, 0.0, lim)  # (0.16 - 0.02) / 0.28 = 0.5 of max, to the right
    assert half.vy == pytest.approx(-0.2) and half.vx == 0.0
    diag = from_offset(1.0, 1.0, 5.0, lim)  # saturates, keeps direction, yaw clamped
    assert diag.vx / lim.max_vx == pytest.approx(math.sqrt(0.5))
    assert diag.yaw_rate == lim.max_yaw_rate


def test_joystick_taps_step_and_clamp():
    lim = JoystickLimits(max_vx=0.6, step_fraction=0.25)
    cmd = VelocityCommand()
    for _ in range(6):
        cmd = tap(cmd, "vx", 1, lim)
    assert cmd.vx == pytest.approx(0.6)
    cmd = tap(tap(cmd, "yaw_rate", -1, lim), "vx", -1, lim)
    assert cmd.vx == pytest.approx(0.45) and cmd.yaw_rate == pytest.approx(-0.25)
    assert cmd.payload() == {"vx": cmd.vx, "vy": 0.0, "yaw_rate": cmd.yaw_rate}
    with pytest.raises(ValueError, match="axis"):
        tap(cmd, "vz", 1, lim)


def test_friction_usage_and_colour():
    n = np.array([0.0, 0.0, 1.0])
    assert friction_usage(np.array([3.0, 4.0, 10.0]), n, 1.0) == pytest.approx(0.5)
    assert friction_usage(np.array([0.0, 0.0, 10.0]), n, 0.7) == 0.0
    assert friction_usage(np.array([1.0, 0.0, -1.0]), n, 0.7) == math.inf
    green, red = usage_colour(0.0), usage_colour(1.0)
    assert green[1] > green[0] and red[0] > red[1]
    assert usage_colour(math.inf) == red == usage_colour(3.0)
    mid = usage_colour(0.5)
    assert mid[0] > 200 and mid[1] > 180  # yellow


def test_spring_force_direction_and_cap():
    s = Spring(stiffness=400.0, max_force=300.0)
    f = spring_force(np.zeros(3), np.array([0.1, 0.0, 0.0]), s)
    np.testing.assert_allclose(f, [40.0, 0.0, 0.0])
    f = spring_force(np.array([1.0, 1.0, 1.0]), np.array([1.0, 3.0, 1.0]), s)
    np.testing.assert_allclose(f, [0.0, 300.0, 0.0])


def test_rolling_buffer_window_ring_and_rewind():
    b = RollingBuffer(2, window=1.0, capacity=50)
    for k in range(300):
        b.append(k * 0.01, [k, -k])
    t, y0, y1 = b.arrays()
    assert t[0] >= 2.99 - 1.0 - 1e-9 and t[-1] == pytest.approx(2.99)
    assert len(t) <= 50 and np.all(np.diff(t) > 0)
    np.testing.assert_allclose(y1, -y0)
    b.append(0.5, [1, 1])  # clock rewound by a reset
    assert len(b) == 1
    with pytest.raises(ValueError, match="expected 2"):
        b.append(0.6, [1, 2, 3])


def test_gait_options_keep_the_experiments_out_unless_one_runs():
    gaits = ["stand", "height_step", "forward_shift", "trot", "crawl", "static_walk"]
    assert gait_options(gaits, "stand") == ("stand", "trot", "crawl")
    assert gait_options(gaits, "crawl") == ("stand", "trot", "crawl")
    # a scenario started an experiment: the dropdown still shows what runs
    assert gait_options(gaits, "height_step") == ("stand", "trot", "crawl", "height_step")
    assert gait_options(["stand"], "stand") == ("stand",)


def test_control_ownership():
    c = ControlOwnership()
    assert c.claim_if_free(1) and not c.claim_if_free(2)
    assert c.take(2) == 1 and c.is_owner(2) and not c.is_owner(1)
    assert not c.release(1) and c.release(2) and c.owner is None


def test_support_polygon_hull_and_degenerate_cases():
    from lab.ui.support import polygon_bounds, sole_corners, support_polygon

    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 0]], float)
    hull = support_polygon(square)
    assert len(hull) == 4 and [0.5, 0.5, 0] not in hull.tolist()
    x = hull[:, 0] - 0.5
    y = hull[:, 1] - 0.5
    assert np.all(np.diff(np.unwrap(np.arctan2(y, x))) > 0)  # counter-clockwise
    line = support_polygon(np.array([[0, 0, 0], [2, 0, 0], [1, 0, 0]], float))
    assert sorted(line[:, 0].tolist()) == [0.0, 2.0]
    assert polygon_bounds(hull) == (0.0, 1.0, 0.0, 1.0)
    yaw90 = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    corners = sole_corners(np.array([1.0, 0.0, 0.0]), yaw90, 0.1, 0.05)
    assert polygon_bounds(corners) == pytest.approx((0.95, 1.05, -0.1, 0.1))
