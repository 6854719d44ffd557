"""A scenario's `[expect]` table: parsed when the scenario loads (unknown numbers refused by
name), checked by `lab run` after a whole run (exit 1 naming what failed), skipped with a note
for a run cut by --duration; every shipped scenario states one."""

import json
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from lab.experiments.expect import Bound, Expectation, check_expect, failed_checks
from lab.experiments.scenario import ScenarioError, load_scenario

SCENARIOS = Path(__file__).resolve().parent.parent.parent / "scenarios"
SHORT = 'robot = "solo12"\nduration = 0.1\n'


def _lab_run(path: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "lab", "run", str(path), "--json", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_every_shipped_scenario_states_whether_it_falls() -> None:
    for path in sorted(SCENARIOS.glob("*.toml")):
        scenario = load_scenario(path)
        assert scenario.expect is not None, f"{path.name} has no [expect]"
        assert scenario.expect.fell is not None, f"{path.name}: [expect] does not state fell"


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("[expect]\ndistance_m = { min = 1.0 }\n", "'distance_m' is not a number"),
        ("[expect]\nfell = 0\n", "fell must be true or false"),
        ("[expect]\nmax_base_height_error_m = 0.01\n", "must be { min"),
        ("[expect]\nmax_base_height_error_m = { below = 0.01 }\n", "must be { min"),
        ("[expect]\nmax_base_height_error_m = { max = nan }\n", "finite number"),
        ("[expect]\nmax_base_height_error_m = { min = 2.0, max = 1.0 }\n", "min 2.0 is above"),
        ("[expect]\n", "[expect] is empty"),
        ("expect = 3\n", "must be a table"),
    ],
)
def test_a_malformed_expect_names_its_problem(tmp_path: Path, text: str, needle: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(SHORT + text)
    with pytest.raises(ScenarioError, match=needle.replace("[", r"\[").replace("{", r"\{")):
        load_scenario(path)


def test_numbered_and_report_fields_are_known(tmp_path: Path) -> None:
    path = tmp_path / "ok.toml"
    path.write_text(
        SHORT + 'metrics = ["pushes"]\n[expect]\nfell = false\npush3_max_cog_error_m = '
        "{ max = 0.01 }\nqp_failures = { max = 0 }\n"
    )
    expect = load_scenario(path).expect
    assert expect == Expectation(
        False, (Bound("push3_max_cog_error_m", None, 0.01), Bound("qp_failures", None, 0))
    )


def test_checks_name_the_bound_and_the_value() -> None:
    expectation = Expectation(
        False, (Bound("distance_m", 9.0, None), Bound("qp_failures", None, 0), Bound("absent", 0))
    )
    report = {"fell": True, "qp_failures": 0, "metrics": {"distance_m": 8.5}}
    section = check_expect(expectation, report)
    assert section["checked"] and section["passed"] is False
    assert [c["passed"] for c in section["checks"]] == [False, False, True, False]
    assert failed_checks(section) == [
        "fell = True, expected False",
        "distance_m = 8.5, expected min 9",
        "absent = None, expected min 0",
    ]
    report = {"fell": False, "qp_failures": 0, "metrics": {"distance_m": 9.5, "absent": 1.0}}
    assert check_expect(expectation, report)["passed"] is True


def test_lab_run_exits_1_naming_the_failed_expectation(tmp_path: Path) -> None:
    path = tmp_path / "strict.toml"
    path.write_text(SHORT + "[expect]\nfell = false\nmax_base_height_error_m = { max = 0.0 }\n")
    result = _lab_run(path)
    assert result.returncode == 1, result.stderr
    assert "expectation failed: max_base_height_error_m" in result.stderr
    report = json.loads(result.stdout)
    checks = {c["name"]: c for c in report["expect"]["checks"]}
    assert checks["fell"]["passed"] and not checks["max_base_height_error_m"]["passed"]
    assert checks["max_base_height_error_m"]["max"] == 0.0
    assert report["expect"]["passed"] is False


def test_lab_run_exits_0_when_the_expectation_holds_and_skips_a_cut_run(tmp_path: Path) -> None:
    path = tmp_path / "holds.toml"
    path.write_text(SHORT + "[expect]\nfell = false\nmax_base_height_error_m = { max = 0.01 }\n")
    result = _lab_run(path)
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout)["expect"]["passed"] is True
    cut = _lab_run(path, "--duration", "0.05")
    assert cut.returncode == 0, cut.stderr
    section = json.loads(cut.stdout)["expect"]
    assert section["checked"] is False and "cut to 0.05 s of 0.1" in section["note"]
    assert "not checked" in cut.stderr


def test_lab_run_exits_2_on_a_bad_expect(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(SHORT + "[expect]\nno_such_number = { max = 1 }\n")
    result = _lab_run(path)
    assert result.returncode == 2 and "no_such_number" in result.stderr


def test_a_sweep_point_does_not_inherit_the_base_expectation(tmp_path: Path) -> None:
    from lab.experiments.sweep.spec import check_scenario, load_sweep

    base = SCENARIOS / "anymal_push_lateral.toml"
    assert "expect" in tomllib.loads(base.read_text())
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'base = "{base}"\nduration = 1.5\n[grid]\n"push.force_n" = [10.0]\n')
    (point,) = load_sweep(sweep).points
    assert check_scenario(point.scenario, base).expect is None


def test_every_shipped_scenario_runs_whole_in_exactly_one_group() -> None:
    from tests.helpers.scenario_runs import GROUPS, groups

    members = [path for group in groups() for path in group]
    assert sorted(members) == sorted(SCENARIOS.glob("*.toml"))
    assert len(groups()) == GROUPS
    for k in range(1, GROUPS + 1):
        assert (Path(__file__).parent / f"test_scenario_runs_{k}.py").exists()


def test_every_metric_lists_its_keys() -> None:
    from lab.experiments.expect import METRIC_KEYS
    from lab.experiments.metrics import METRICS

    assert set(METRIC_KEYS) == set(METRICS)
