"""Herzog 2016 §5.2's scenes on Talos, run short from their scenarios: a block under one foot,
a rolling platform and a balance board with its drop. Each asserts the robot stands, the
measured CoP stays inside the soles and the terrain did move as scripted."""

from pathlib import Path

import numpy as np
import pytest
import viser

from lab.experiments.scenario import load_scenario, run_scenario
from lab.scenes.balance_board import TILT_MAX, TILT_MIN
from lab.scenes.block import HEIGHT
from lab.scenes.platform import platform_pose
from lab.ui.terrain_view import TerrainView
from lab.world.session import Session, SessionConfig
from lab.world.telemetry import state_message
from tests.helpers.ports import free_port

SCENARIOS = Path(__file__).resolve().parent.parent.parent / "scenarios"
# Loaded sole-ticks whose measured CoP is within 5 mm of the sole's edge (sole_cop's INSIDE_TOL):
# none on the block and the platform; the drop tips the feet for a few tens of milliseconds.
MAX_EDGE_TIME = 0.1  # s, the balance board's drop (measured: 0.03 s)


def _run(name: str, seconds: float) -> dict:
    report = run_scenario(load_scenario(SCENARIOS / f"herzog_{name}.toml"), seconds)
    assert report["fell"] is False
    assert report["qp_failures"] == 0 and report["divergences"] == 0
    return report["metrics"]


def test_block_stands_with_one_foot_raised() -> None:
    """The left sole starts on the 4 cm block and stays there; measured: CoG error 0.1 mm, the
    CoP at most 48 % of the half sole from its centre."""
    metrics = _run("block", 1.5)
    assert metrics["cog_error_max_m"] < 0.01
    assert metrics["cop_at_edge_s"] == 0.0
    assert max(metrics["cop_sole_fraction_x_max"], metrics["cop_sole_fraction_y_max"]) < 0.9
    assert metrics["sole_slip_max_m"] < 0.005  # both soles, the left one on the block
    session = Session(SessionConfig(robot="talos", scene="block"))
    heights = session.model.contact_positions[:, 2]
    assert heights == pytest.approx([HEIGHT, 0.0], abs=1e-6)


def test_block_is_refused_for_a_quadruped() -> None:
    """Refused by name, at start and as a live switch, which changes nothing."""
    with pytest.raises(ValueError, match="made for robot talos"):
        Session(SessionConfig(robot="solo12", scene="block"))
    session = Session(SessionConfig(robot="solo12"))
    reply = session.handle("scene", {"name": "block"})
    assert not reply["ok"] and "made for robot talos" in reply["error"]
    assert session.config.scene == "flat"


def test_platform_moves_and_the_soles_go_with_it() -> None:
    """2 s: the platform's roll reaches ≥ 2° and its y shift ≥ 2.5 cm; the soles slip less
    than 1 cm on it and the CoP never reaches the edge."""
    metrics = _run("platform", 2.0)
    assert max(-metrics["platform_joint_1_min"], metrics["platform_joint_1_max"]) > 0.025
    assert max(-metrics["platform_joint_5_min"], metrics["platform_joint_5_max"]) > np.radians(2)
    assert metrics["sole_slip_max_m"] < 0.01
    assert metrics["cop_at_edge_s"] == 0.0
    assert metrics["cog_error_max_m"] < 0.03


def test_balance_board_tilts_through_its_range_and_drops() -> None:
    """2.5 s: the board is driven to −2.8° and 5.6° (±0.3°; held at 5.49° under the robot's
    weight) and dropped at 2 s onto its lower limit; Talos stands, its CoP at a sole's edge only
    for the instants of the impact."""
    metrics = _run("balance_board", 2.5)
    low, high = metrics["board_joint_0_min"], metrics["board_joint_0_max"]
    # the impact presses the loaded board past its soft limit for an instant (measured: 0.47°)
    assert TILT_MIN - np.radians(1.0) < low < TILT_MIN + np.radians(0.3)
    assert high == pytest.approx(TILT_MAX, abs=np.radians(0.3))
    assert metrics["cop_at_edge_s"] < MAX_EDGE_TIME
    assert metrics["cop_inside_fraction"] > 0.97
    assert metrics["cog_error_max_m"] < 0.03


def test_a_reset_after_the_drop_sets_talos_on_a_held_board() -> None:
    """A reset at a sim time past the board's drop (as after a diverged simulation, which keeps
    the clock) restarts the board's script: the board is held level under the robot, not let go
    (which dropped it with Talos on it to its lower limit, 2.3 cm under the feet)."""
    session = Session(SessionConfig(robot="talos", scene="balance_board"))
    board = session.plant.moving_terrain
    session.plant.reset(session.robot.q_standing, time=3.0)
    assert session.plant.mj_data.eq_active[0]
    height = session.model.contact_positions[:, 2].copy()
    while session.time < 3.25:  # the script holds the board level for its first 0.3 s
        session.tick()
    assert not session.fell
    tilt = session.plant.mj_data.qpos[board._qpos[0]]
    assert np.abs(tilt) < np.radians(0.5)  # the soft hold gives 0.1° under the robot
    assert session.model.contact_positions[:, 2] == pytest.approx(height, abs=2e-3)


def test_the_state_carries_the_platform_where_it_is_and_the_view_draws_it_there() -> None:
    """Solo12 on the platform (the moving scenes load for any robot): after 1.5 s the pose in
    `lab/state` is the script's (y within 2 mm), and the terrain view's frame takes it."""
    session = Session(SessionConfig(robot="solo12", scene="platform"))
    assert state_message(session)["scene_bodies"]["platform"] == pytest.approx(
        [0, 0, 0, 1, 0, 0, 0]
    )
    while session.time < 1.5:
        session.tick()
    assert not session.fell
    pose = state_message(session)["scene_bodies"]["platform"]
    assert pose[1] == pytest.approx(platform_pose(session.time)[1], abs=2e-3)
    assert abs(pose[1]) > 0.01
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        view = TerrainView(server, "platform")
        view.set_poses({"platform": pose, "gone": [0.0] * 7})  # an unknown body is ignored
        frame = view._bodies["platform"]
        assert frame.position == pytest.approx(pose[:3])
        assert frame.wxyz == pytest.approx(pose[3:])
        view.remove()
    finally:
        server.stop()
