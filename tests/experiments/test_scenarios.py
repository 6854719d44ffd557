"""The shipped scenarios: every robot's standing and push scenarios exist and their whole runs
expect what short runs of them were held to (no fall, the errors within stated bounds), `lab run`
prints one report, and a malformed scenario is refused naming its problem."""

import functools
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from lab import stack_presets
from lab.cli import main
from lab.experiments.expect import Bound
from lab.experiments.scenario import ScenarioError, load_scenario
from lab.world.session import Session, SessionConfig

SCENARIOS = Path(__file__).resolve().parent.parent.parent / "scenarios"
STANDING = sorted(SCENARIOS.glob("*_stand_*.toml"))
PUSHES = sorted(SCENARIOS.glob("*_push_lateral.toml"))

MAX_ORIENTATION_ERROR = 0.01  # rad, standing
MAX_HEIGHT_ERROR = 0.005  # m, standing
PUSH_MAX_ORIENTATION_ERROR = 0.1  # rad, while pushed
PUSH_MAX_HEIGHT_ERROR = 0.03  # m, while pushed
PUSH = '[[events]]\nt = 0.5\npush = {{ body = "base", force = {force}, duration = {d} }}\n'
GAINS = r"bad.toml: \[controller.gains."  # how a scenario's gain errors begin


def test_every_robot_and_method_has_a_standing_scenario() -> None:
    names = {p.stem for p in STANDING}
    for robot in ("anymal", "hyq", "solo12", "talos"):
        assert {f"{robot}_stand_cascade", f"{robot}_stand_weighted"} <= names
        assert (SCENARIOS / f"{robot}_push_lateral.toml").exists()


def _bounds(path: Path) -> dict[str, Bound]:
    """The bounds of the scenario's [expect] table, by name (fell must be stated false)."""
    expect = load_scenario(path).expect
    assert expect is not None and expect.fell is False, path.name
    return {bound.name: bound for bound in expect.bounds}


def _at_most(bound: Bound | None, limit: float) -> bool:
    return bound is not None and bound.maximum is not None and bound.maximum <= limit


@pytest.mark.parametrize("path", STANDING, ids=lambda p: p.stem)
def test_a_standing_run_expects_no_fall_no_failure_and_the_standing_bounds(path: Path) -> None:
    """Each standing scenario's whole run (tests/experiments/test_scenario_runs_*.py: 10 s to its
    end, its [expect] checked) is held to what a 1.5 s short run of it was held to here: no
    fall, no QP failure, base orientation and height errors within the standing bounds, and
    the peak foot normal force above a quarter of the weight (the weight is carried) and below
    1.2 times it (no foot carries more than the whole weight). A divergence ends a run short,
    which the whole run's check fails (tests/helpers/scenario_runs.py)."""
    bounds = _bounds(path)
    assert _at_most(bounds.get("qp_failures"), 0)
    assert _at_most(bounds.get("max_base_orientation_error_rad"), MAX_ORIENTATION_ERROR)
    assert _at_most(bounds.get("max_base_height_error_m"), MAX_HEIGHT_ERROR)
    weight = _weight(load_scenario(path).config.robot)
    peak = bounds.get("peak_contact_normal_force_n")
    assert _at_most(peak, 1.2 * weight), (peak, weight)
    assert peak.minimum is not None and peak.minimum >= weight / 4, (peak, weight)


@pytest.mark.parametrize("path", PUSHES, ids=lambda p: p.stem)
def test_a_lateral_push_run_expects_it_survived_within_the_push_bounds(path: Path) -> None:
    """Each lateral push scenario's whole run (4 s, the push and its recovery, its [expect]
    checked by tests/experiments/test_scenario_runs_*.py) is held to what a run to 1 s after
    the push was held to here: no fall, no QP failure, base orientation and height errors within
    the bounds while pushed."""
    bounds = _bounds(path)
    assert _at_most(bounds.get("qp_failures"), 0)
    assert _at_most(bounds.get("max_base_orientation_error_rad"), PUSH_MAX_ORIENTATION_ERROR)
    assert _at_most(bounds.get("max_base_height_error_m"), PUSH_MAX_HEIGHT_ERROR)


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
        # non-finite or absurd times and durations (`t = nan` used to never fire, exit 0)
        ("duration = 1.0\n[[events]]\nt = nan\nreset = {}\n", "event 0: t must be a time"),
        ("duration = 1.0\n[[events]]\nt = inf\nreset = {}\n", "event 0: t must be a time"),
        ("duration = 1.0\n[[events]]\nt = -1.0\nreset = {}\n", "event 0: t must be a time"),
        ("duration = 1.0\n[[events]]\nt = 1.5\nreset = {}\n", "before the end .duration 1 s"),
        ("duration = nan\n", "duration must be > 0 and at most DURATION_MAX_S"),
        ("duration = inf\n", "duration must be > 0 and at most DURATION_MAX_S = 3600 s"),
        ("duration = 1e12\n", "duration must be > 0 and at most DURATION_MAX_S = 3600 s"),
        ("duration = -2.0\n", "duration must be > 0"),
        ("duration = true\n", "duration must be a number of seconds"),
        ("duration = 1.0\nevents = [1, 2]\n", "event 0: must be a table"),
        ("duration = 1.0\nevents = 3\n", "events must be"),
        ("duration = 1.0\ncontroller = 5\n", r"\[controller\] must be a table"),
        # non-finite forces, as the protocol refuses them
        (f"duration = 1.0\n{PUSH.format(force='[nan, 0.0, 0.0]', d=0.1)}", r"'force\[0\]' must be"),
        (
            f"duration = 1.0\n{PUSH.format(force='[0.0, -inf, 0.0]', d=0.1)}",
            r"'force\[1\]' must be",
        ),
        (f"duration = 1.0\n{PUSH.format(force='[0.0, 9.0, 0.0]', d='inf')}", "'duration' must be"),
        # gains as the `gains` command checks them (kp = -5 used to be accepted)
        (
            "duration = 1.0\n[controller.gains.posture]\nkp = -5.0\n",
            GAINS + r"posture\]: field 'kp'",
        ),
        (
            "duration = 1.0\n[controller.gains.posture]\nkd = nan\n",
            GAINS + r"posture\]: field 'kd'",
        ),
        ("duration = 1.0\n[controller.gains.posture]\nkpp = 1.0\n", r"unknown field\(s\) 'kpp'"),
        (
            "duration = 1.0\n[controller.gains.no_such_task]\nkp = 1.0\n",
            "no_such_task\\]: unknown task",
        ),
        ("duration = 1.0\n[controller]\ngains = 3\n", r"gains\]: must be a table of tasks"),
        (
            'duration = 1.0\n[controller]\nstack = "raiola_s3"\n'
            "[controller.gains.posture]\nweight = 0.0\n",
            GAINS + r"posture\]: field 'weight' = 0 is out of range \(0",
        ),
    ],
)
def test_a_malformed_scenario_names_its_problem(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, needle: str
) -> None:
    """Refused before running, naming the field; `lab run` prints one line and exits 2."""
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=needle):
        load_scenario(path)
    assert main(["run", str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and re.search(needle, err), err


def test_a_binary_file_is_no_scenario(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "photo.toml"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\xff\xfe")
    assert main(["run", str(path)]) == 2
    assert "not a text file (byte 0 is not UTF-8)" in capsys.readouterr().err
    for duration in ("nan", "inf", "-1", "1e12"):  # and a --duration that cannot be one
        assert main(["run", str(STANDING[0]), "--duration", duration]) == 2
        assert "--duration must be" in capsys.readouterr().err


def test_a_stack_preset_with_a_bad_gain_is_refused_not_raised(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A typo in a preset's [gains] used to let a TypeError out of Session.handle."""
    (tmp_path / "typo.toml").write_text(
        'method = "cascade"\nlevels = [["contact"], ["posture"]]\n[gains.posture]\nkpp = 1.0\n'
    )
    monkeypatch.setattr(stack_presets, "STACKS_DIR", tmp_path)
    monkeypatch.setattr(stack_presets, "PRESET_NAMES", ("typo",))
    with pytest.raises(ValueError, match=r"typo.toml: \[gains.posture\]: unknown field\(s\) 'kpp'"):
        stack_presets.load_stack_preset("typo")
    session = Session(SessionConfig(robot="anymal"))
    stack = session.controller.config.stack
    reply = session.handle("stack", {"preset": "typo"})
    assert not reply["ok"] and "unknown field(s) 'kpp'" in reply["error"], reply
    assert session.controller.config.stack is stack  # refused: nothing changed


@functools.cache
def _weight(robot: str) -> float:
    """The robot's weight (N)."""
    from lab.description import load_description
    from lab.robot import build_robot

    model = build_robot(load_description(robot)).model
    return sum(inertia.mass for inertia in model.inertias) * 9.81
