"""The locomotion scenarios, run short (2.5-4 s instead of 10-24 s), against their metrics.

Event times of the gait-switching and push scenarios are compressed so that the short runs still
switch gait twice and take two pushes. Averages skip the first second (the start from standing).
"""

from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from lab.experiments.metrics.locomotion import LocomotionMetrics
from lab.experiments.scenario import Scenario, load_scenario, run_scenario

SCENARIOS = Path(__file__).resolve().parent.parent.parent / "scenarios"
MAX_MEAN_ATTITUDE = 0.01  # rad, mean |roll| and |pitch| (Raiola Table 3: below 0.01 rad)


def _load(name: str) -> Scenario:
    return load_scenario(SCENARIOS / f"{name}.toml")


def _compressed(scenario: Scenario, factor: float) -> Scenario:
    events = [replace(e, t=e.t * factor) for e in scenario.events]
    return replace(scenario, events=events, duration=scenario.duration * factor)


def _walked(report: dict) -> dict:
    assert report["fell"] is False
    assert report["qp_failures"] == 0
    assert report["rejected_events"] == []
    return report["metrics"]


def test_anymal_trots_at_half_a_metre_per_second_with_a_level_trunk() -> None:
    metrics = _walked(run_scenario(_load("anymal_trot_flat"), 3.0))
    # S3 has no velocity task: the stance legs' posture references move the base (Raiola eqs.
    # 30-32; measured 0.505 m/s over 20 s, mean |v - v_cmd| 0.062 m/s with the trot's sway).
    assert metrics["mean_vx_mps"] == pytest.approx(0.5, abs=0.05)
    assert abs(metrics["mean_vy_mps"]) < 0.03
    assert metrics["mean_velocity_error_mps"] < 0.15  # 2 s of averaging, right after the start
    assert metrics["mean_abs_roll_rad"] < MAX_MEAN_ATTITUDE
    assert metrics["mean_abs_pitch_rad"] < MAX_MEAN_ATTITUDE
    assert metrics["distance_m"] > 0.6


@pytest.mark.parametrize("stack", ["s3", "s1"])
def test_crawl_trot_crawl_switches_while_walking(stack: str) -> None:
    scenario = _compressed(_load(f"anymal_crawl_trot_crawl_{stack}"), 0.3)  # switches at 1.2, 2.4 s
    metrics = _walked(run_scenario(scenario))
    assert scenario.duration == pytest.approx(3.6)
    assert metrics["mean_vx_mps"] == pytest.approx(0.2, abs=0.04)  # never stopped
    assert metrics["mean_abs_roll_rad"] < 2 * MAX_MEAN_ATTITUDE
    assert metrics["mean_abs_pitch_rad"] < 2 * MAX_MEAN_ATTITUDE


@pytest.mark.parametrize("robot", ["anymal", "hyq"])
def test_blind_trot_over_rough_ground(robot: str) -> None:
    # HyQ's hind shins graze tile edges now and then; a stumble, not a fall (docs/locomotion.md).
    metrics = _walked(run_scenario(_load(f"{robot}_trot_rough"), 3.0))
    assert metrics["distance_m"] > 0.6  # onto the tiles, which start 0.6 m ahead
    assert metrics["mean_abs_roll_rad"] < 3 * MAX_MEAN_ATTITUDE
    assert metrics["mean_abs_pitch_rad"] < 3 * MAX_MEAN_ATTITUDE


def test_trot_survives_lateral_kicks() -> None:
    scenario = _compressed(_load("anymal_trot_lateral_kicks"), 0.5)  # 20 N s, then 40 N s
    metrics = _walked(run_scenario(scenario, 3.7))
    assert metrics["largest_push_survived_ns"] == pytest.approx(40.0, rel=0.01)


def _pushed_run(fall_at: float | None, next_push_at: float) -> dict:
    """The locomotion metrics of a standing robot (stub session, 10 ms ticks, 4 s) pushed with
    10 N s over [1.0, 1.1) s and 30 N s at `next_push_at`, falling at `fall_at`."""
    model = SimpleNamespace(
        q=np.zeros(9),
        base_rotation=np.eye(3),
        base_linear_velocity_world=np.zeros(3),
        base_angular_velocity_world=np.zeros(3),
    )
    session = SimpleNamespace(
        model=model, config=SimpleNamespace(timestep=0.01), velocity=np.zeros(3), fell=False
    )
    session.time, session.pushes = 0.0, {}
    metrics = LocomotionMetrics(session)
    for tick in range(400):
        session.time = 0.01 * tick
        pushes = ((1.0, 100.0), (next_push_at, 300.0))
        force = [f for start, f in pushes if start <= session.time < start + 0.1 - 1e-9]
        session.pushes = (
            {"base": SimpleNamespace(force=np.array([0.0, *force, 0.0]))} if force else {}
        )
        session.fell = fall_at is not None and session.time >= fall_at
        metrics.update(session)
        if session.fell:
            break
    return metrics.result()


def test_a_push_counts_as_survived_only_without_a_fall_before_the_next_one() -> None:
    # Standing 1.2 s after the push is not enough when the robot falls before the next one.
    assert _pushed_run(fall_at=2.3, next_push_at=3.0)["largest_push_survived_ns"] == 0.0
    assert _pushed_run(fall_at=3.5, next_push_at=2.5)["largest_push_survived_ns"] == pytest.approx(
        10
    )
    # No fall: both count, the second one judged at the end of the run (0.9 s is too short).
    assert _pushed_run(None, next_push_at=2.5)["largest_push_survived_ns"] == pytest.approx(30)
    assert _pushed_run(None, next_push_at=3.0)["largest_push_survived_ns"] == pytest.approx(10)


def test_solo12_turns_in_place() -> None:
    metrics = _walked(run_scenario(_load("solo12_trot_turn"), 2.5))
    assert metrics["mean_yaw_rate_radps"] == pytest.approx(0.5, abs=0.05)
    assert metrics["distance_m"] < 0.05


def test_solo12_strafes() -> None:
    metrics = _walked(run_scenario(_load("solo12_trot_strafe"), 2.5))
    # Commanded 0.15 m/s; measured 0.152 m/s over 10 s.
    assert metrics["mean_vy_mps"] == pytest.approx(0.15, abs=0.03)
    assert abs(metrics["mean_vx_mps"]) < 0.03
    assert abs(metrics["mean_yaw_rate_radps"]) < 0.05
