"""The shipped scenarios, run short: nobody falls and the errors stay within stated bounds."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from lab.server.scenario import ScenarioError, load_scenario, run_scenario

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
STANDING = sorted(SCENARIOS.glob("*_stand_*.toml"))
PUSHES = sorted(SCENARIOS.glob("*_push_lateral.toml"))

STAND_SECONDS = 1.5  # short versions of the 10 s scenarios
MAX_ORIENTATION_ERROR = 0.01  # rad, standing
MAX_HEIGHT_ERROR = 0.005  # m, standing
PUSH_MAX_ORIENTATION_ERROR = 0.1  # rad, while pushed
PUSH_MAX_HEIGHT_ERROR = 0.03  # m, while pushed


def test_every_robot_and_method_has_a_standing_scenario() -> None:
    names = {p.stem for p in STANDING}
    for robot in ("anymal", "hyq", "solo12", "talos"):
        assert {f"{robot}_stand_cascade", f"{robot}_stand_weighted"} <= names
        assert (SCENARIOS / f"{robot}_push_lateral.toml").exists()


@pytest.mark.parametrize("path", STANDING, ids=lambda p: p.stem)
def test_standing(path: Path) -> None:
    scenario = load_scenario(path)
    report = run_scenario(scenario, STAND_SECONDS)
    weight = _weight(scenario.config.robot)
    assert report["fell"] is False
    assert report["qp_failures"] == 0 and report["divergences"] == 0
    assert report["sim_time_s"] == pytest.approx(STAND_SECONDS, abs=2e-3)
    metrics = report["metrics"]
    assert metrics["max_base_orientation_error_rad"] <= MAX_ORIENTATION_ERROR
    assert metrics["max_base_height_error_m"] <= MAX_HEIGHT_ERROR
    # No foot carries more than the whole weight, and the weight is carried at all.
    assert weight / 4 < metrics["peak_contact_normal_force_n"] < 1.2 * weight


@pytest.mark.parametrize("path", PUSHES, ids=lambda p: p.stem)
def test_lateral_push_is_survived(path: Path) -> None:
    scenario = load_scenario(path)
    push = scenario.events[0]
    report = run_scenario(scenario, push.t + push.payload["duration"] + 1.0)
    assert report["fell"] is False
    assert report["qp_failures"] == 0 and report["divergences"] == 0
    metrics = report["metrics"]
    assert metrics["max_base_orientation_error_rad"] <= PUSH_MAX_ORIENTATION_ERROR
    assert metrics["max_base_height_error_m"] <= PUSH_MAX_HEIGHT_ERROR


def test_lab_run_prints_one_json_report() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "lab", "run", str(STANDING[0]), "--json", "--duration", "0.2"],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    )
    report = json.loads(result.stdout)
    keys = ("fell", "divergences", "sim_time_s", "wall_time_s", "realtime_factor", "qp_failures")
    for key in (*keys, "metrics"):
        assert key in report
    assert set(report["tick_us"]) == {"p50", "p99", "max"}
    assert report["tick_us"]["p50"] <= report["tick_us"]["p99"] <= report["tick_us"]["max"]


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ('robot = "anymal"\n', "duration"),
        ("duration = 1.0\nspeed = 2\n", "speed"),
        ('duration = 1.0\n[[events]]\nt = 0.5\npush = { body = "base" }\n', "force"),
        ("duration = 1.0\n[[events]]\nt = 0.5\nreset = {}\npause = {}\n", "exactly one"),
        ("duration = 1.0\n[[events]]\nt = 0.5\nfly = {}\n", "fly"),
        (
            'duration = 1.0\n[controller]\nhierarchy = "cascade"\n',
            "'hierarchy' is now called 'method'",
        ),
        ('duration = 1.0\n[controller]\nalgorithm = "cascade"\n', "algorithm"),
        ('duration = 1.0\n[controller]\nkernel = "fast"\n', "kernel must be one of"),
    ],
)
def test_a_malformed_scenario_names_its_problem(tmp_path: Path, text: str, needle: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=needle):
        load_scenario(path)


def _weight(robot: str) -> float:
    from lab.description import load_description
    from lab.robot import build_robot

    model = build_robot(load_description(robot)).model
    return sum(inertia.mass for inertia in model.inertias) * 9.81
