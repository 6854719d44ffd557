"""A short soak: the loop in fast mode under a seeded random user (lab/server/soak.py); the
hour-long one is run by hand and its numbers are in docs/reliability.md."""

import json
import subprocess
import sys

from lab.server.soak import COMMAND_INTERVAL_S, MAX_MEMORY_GROWTH, soak

SIM_SECONDS = 30.0


def test_a_short_soak_ends_standing_with_every_fall_undone_and_flat_memory() -> None:
    report = soak("anymal", SIM_SECONDS, seed=3)
    assert report.ok, report.failures
    assert report.error is None and not report.interrupted
    assert report.ticks >= SIM_SECONDS / 1e-3 - 10  # 1 ms steps, up to one telemetry period
    sent = sum(report.commands.values())
    assert sent > 0.5 * SIM_SECONDS / COMMAND_INTERVAL_S, report.commands
    assert report.unrecovered_falls == 0 and report.resets_after_fall <= report.falls
    assert report.memory_growth < MAX_MEMORY_GROWTH, report.rss_mb
    assert report.loop["ticks"] == report.ticks


def test_the_soak_command_refuses_a_bad_duration_and_an_unknown_robot() -> None:
    for args, message in (
        (["--sim-seconds", "0"], "--sim-seconds must be positive"),
        (["--sim-seconds", "1", "--robot", "nobody"], "unknown robot 'nobody'"),
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
