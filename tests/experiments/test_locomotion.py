"""The locomotion scenarios, run short (3-3.6 s instead of 12-24 s), for what their whole runs'
[expect] tables do not hold: that the gait switches are accepted while walking, and the trunk's
mean |roll| and |pitch| on rough ground. The whole runs (tests/helpers/scenario_runs.py) check the
rest to tighter bounds: anymal_trot_flat (v_x 0.48-0.53 m/s, drift ≤ 0.02 m/s so |v_y| ≤ 0.02,
mean ‖v − v_cmd‖ ≤ 0.15 m/s, |roll| ≤ 0.005, |pitch| ≤ 0.0072 rad, 9.5-10.5 m), both stacks'
crawl-trot-crawl (v_x 0.19-0.21 m/s, the same attitude bounds), anymal_trot_lateral_kicks (the
largest kick survived 60-80 N s), solo12_trot_turn (0.49-0.51 rad/s, < 1 mm) and
solo12_trot_strafe (v_y 0.14-0.16 m/s, mean ‖v − v_cmd‖ ≤ 0.03 m/s so |v_x| ≤ 0.03, yaw rate
within ±0.05 rad/s).

Event times of the gait-switching scenario are compressed so that the short run still switches
gait twice. Averages skip the first second (the start from standing).
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


def test_crawl_trot_crawl_switches_while_walking() -> None:
    """The gait events are accepted while walking (s3; the stack does not decide a switch)."""
    scenario = _compressed(_load("anymal_crawl_trot_crawl_s3"), 0.3)  # switches at 1.2, 2.4 s
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
