"""A short soak: the loop in fast mode under a seeded random user (lab/experiments/soak.py); the
hour-long one is run by hand and its numbers are in docs/reliability.md."""

import json
import subprocess
import sys

import pytest

from lab.experiments.soak import (
    COMMAND_INTERVAL_S,
    FALLEN_S,
    MAX_MEMORY_GROWTH,
    RESET_CHECK_S,
    RandomUser,
    soak,
)

SIM_SECONDS = 30.0


def test_a_short_soak_ends_standing_with_every_fall_undone_and_flat_memory() -> None:
    report = soak("anymal", SIM_SECONDS, seed=3)
    assert report.ok, report.failures
    assert report.error is None and not report.interrupted
    steps = SIM_SECONDS / 1e-3  # 1 ms steps; the loop also counts a paused tick or a few
    assert steps - 10 <= report.ticks <= 1.02 * steps  # up to one telemetry period short
    sent = sum(report.commands.values())
    assert sent > 0.5 * SIM_SECONDS / COMMAND_INTERVAL_S, report.commands
    assert report.unrecovered_falls == 0 and report.resets_after_fall <= report.falls
    assert report.memory_growth < MAX_MEMORY_GROWTH, report.rss_mb
    assert report.loop["ticks"] == report.ticks


def test_the_soak_command_refuses_a_bad_duration_an_unknown_robot_and_method() -> None:
    for args, message in (
        (["--sim-seconds", "0"], "--sim-seconds must be positive"),
        (["--sim-seconds", "1", "--robot", "nobody"], "unknown robot 'nobody'"),
        (["--sim-seconds", "1", "--methods", "cascade,simplex"], "unknown method(s) simplex"),
    ):
        run = subprocess.run(
            [sys.executable, "-m", "lab", "soak", *args], capture_output=True, text=True
        )
        assert run.returncode == 2 and message in run.stderr, run.stderr


def test_the_soak_report_is_one_json_object() -> None:
    run = subprocess.run(
        [sys.executable, "-m", "lab", "soak", "--sim-seconds", "2", "--json"],
        capture_output=True,
        text=True,
    )
    report = json.loads(run.stdout)
    assert run.returncode == (0 if report["ok"] else 1)
    assert report["sim_seconds"] == 2.0 and report["ticks"] >= 1990
    assert set(report["rss_mb"]) == {"warm", "end", "max"}


def _telemetry(t: float, fell: bool, height: float, ticks: int) -> dict:
    return {
        "t": t,
        "fell": fell,
        "paused": False,
        "divergences": 0,
        "qp": {"failures": 0},
        "base": {"position": [0.0, 0.0, height]},
        "loop": {"ticks": ticks},
    }


def test_a_fall_is_reset_and_checked_on_the_soaks_clock_not_the_sessions() -> None:
    """The session's clock restarts at 0 on a reset; the soak's goes on. A robot standing
    RESET_CHECK_S after the reset is a fall undone. One still down gets the defaults back (the
    `robot` command, as the page's "Default stack"); still down RESET_CHECK_S after that is a
    fall the lab cannot reset from."""
    info = {"robot": "test", "gaits": ["stand"], "base": "base", "hierarchy": {"method": "cascade"}}
    for heights, plain, unrecovered in (((0.5,), 0, 0), ((0.1, 0.5), 1, 0), ((0.1, 0.1), 1, 1)):
        user = RandomUser(info, weight_n=500.0, standing_height=0.5, sim_seconds=10.0, seed=0)
        user.publish_telemetry(_telemetry(2.0, True, 0.1, 2000))  # fell at 2 s
        user.publish_telemetry(_telemetry(2.0 + FALLEN_S, True, 0.1, 3000))
        assert user.receive().verb == "reset" and user.report.resets_after_fall == 1
        for k, height in enumerate(heights):
            user.publish_telemetry(_telemetry(0.01, False, 0.5, 3010))  # the clock restarted
            check = _telemetry(RESET_CHECK_S + 0.01, height < 0.4, height, 4000 + k)
            user.publish_telemetry(check)
            if k == 0 and height < 0.4:  # the default method, then the default stack
                sent = [(r.verb, r.payload) for r in (user.receive(), user.receive())]
                assert sent == [("hierarchy", {"method": "cascade"}), ("robot", {"name": "test"})]
        assert user.report.down_after_plain_reset == plain and user.report.falls == 1
        assert user.report.unrecovered_falls == unrecovered
        expected = 3.0 + len(heights) * (RESET_CHECK_S + 0.01)
        assert user.sim_time == pytest.approx(expected)


def test_a_fall_on_a_scene_the_robot_cannot_stand_on_gets_the_default_scene_back() -> None:
    """ANYmal on Bolt's split wedges falls whatever its controller: after a plain reset fails,
    the default method, the default scene and the default stack come back, in that order."""
    info = {"robot": "anymal", "scene": "flat", "hierarchy": {"method": "cascade"}}
    user = RandomUser(info, weight_n=500.0, standing_height=0.5, sim_seconds=10.0, seed=0)
    wedges = {"scene": "split_wedges"}
    user.publish_telemetry(_telemetry(2.0, True, 0.1, 2000) | wedges)
    user.publish_telemetry(_telemetry(2.0 + FALLEN_S, True, 0.1, 3000) | wedges)
    assert user.receive().verb == "reset"
    user.publish_telemetry(_telemetry(0.01, True, 0.1, 3010) | wedges)
    user.publish_telemetry(_telemetry(RESET_CHECK_S + 0.01, True, 0.1, 4000) | wedges)
    sent = [(r.verb, r.payload) for r in (user.receive(), user.receive(), user.receive())]
    assert sent == [
        ("hierarchy", {"method": "cascade"}),
        ("scene", {"name": "flat"}),
        ("robot", {"name": "anymal"}),
    ]
    assert user.report.plain_reset_failed_under == {"? / ? / split_wedges": 1}
