"""Every shipped scenario run to its end with its `[expect]` checked, split into groups.

The test modules `test_scenario_runs_<k>.py` each run one group, so that `./dev test`'s two
pytest-xdist workers (`--dist loadfile`: a whole module per worker) share the runs. The groups
balance WALL_S, each scenario's wall time measured on this 2-core machine (2026-12-03, the
four modules on two workers, `--durations=0`, beside a third busy process; the Bolt and Kim
scenarios and Hutter's on the Python kernel, the rest native).
A scenario not in the table counts as NEW_SCENARIO_S_PER_SIM_S per simulated second, so a new
file joins a group, never no group.
"""

import math
import re
import tomllib
from pathlib import Path

import pytest

from lab.server.expect import METRIC_KEYS, REPORT_FIELDS, failed_checks
from lab.server.scenario import load_scenario, run_scenario

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
GROUPS = 4  # modules tests/test_scenario_runs_1.py … _4.py
NEW_SCENARIO_S_PER_SIM_S = 1.0  # a new scenario's guessed wall time per simulated second

WALL_S: dict[str, float] = {
    "anymal_crawl_trot_crawl_s1": 2.5,
    "anymal_crawl_trot_crawl_s3": 2.7,
    "anymal_push_lateral": 3.2,
    "anymal_stand_cascade": 12.4,
    "anymal_stand_weighted": 1.3,
    "anymal_trot_flat": 3.9,
    "anymal_trot_lateral_kicks": 3.0,
    "anymal_trot_rough": 5.3,
    "anymal_walk_slope": 34.6,
    "b1_z1_reach_circle_stand": 18.0,  # round 12, lab run alone at load 10-30
    "b1_z1_reach_circle_trot": 13.4,
    "bolt_push_recovery": 27.3,
    "bolt_step_in_place": 159.6,
    "bolt_walk_planner": 451.0,
    "herzog_balance_board": 2.2,
    "herzog_balance_board_lateral": 2.6,
    "herzog_balance_board_lateral_pd": 2.3,
    "herzog_balance_board_pd": 2.8,
    "herzog_block": 1.7,
    "herzog_block_pd": 1.6,
    "herzog_leg_swing": 2.7,
    "herzog_platform": 3.6,
    "herzog_platform_pd": 3.6,
    "herzog_single_support": 1.6,
    "herzog_squat_03hz": 4.1,
    "herzog_squat_05hz": 4.9,
    "herzog_squat_cop": 10.9,
    "herzog_table3_lqr": 16.7,
    "herzog_table3_lqr_talos": 30.4,
    "herzog_table3_pd": 27.4,
    "hutter_exp6_height_lowest": 6.0,
    "hutter_exp7_pitch_lowest": 6.4,
    "hutter_half_cylinder_aligned": 12.2,
    "hutter_half_cylinder_vertical": 1.2,
    "hutter_sim1_tau_min": 26.5,
    "hutter_sim2_force_min": 25.3,
    "hutter_sim3_tau_lim_tau_min": 28.6,
    "hutter_sim4_tau_lim_force_min": 30.2,
    "hutter_sim5_knee_hip_limited": 12.2,
    "hutter_sim5_knee_limited": 4.1,
    "hutter_sim9_interpolation": 18.3,
    "hutter_sim9_without_interpolation": 8.7,
    "hyq_push_lateral": 0.6,
    "hyq_stand_cascade": 1.6,
    "hyq_stand_weighted": 1.4,
    "hyq_trot_rough": 5.0,
    "kim_wedges_100n": 4.4,
    "kim_wedges_100n_open_loop": 4.4,
    "kim_wedges_100n_push_down": 4.5,
    "kim_wedges_100n_push_side": 4.2,
    "kim_wedges_10n": 1.2,
    "kim_wedges_ellipse": 6.8,
    "kim_wedges_ellipse_open_loop": 6.4,
    "kim_wedges_impedance_down": 4.7,
    "kim_wedges_impedance_side": 5.0,
    "solo12_push_lateral": 0.6,
    "solo12_stand_cascade": 1.4,
    "solo12_stand_weighted": 1.3,
    "solo12_trot_strafe": 1.9,
    "solo12_trot_turn": 1.9,
    "talos_arms_reach_circle": 24.3,  # round 12, lab run alone at load 10-30
    "talos_arms_reach_two_hands": 43.5,
    "talos_push_lateral": 0.7,
    "talos_stand_cascade": 1.5,
    "talos_stand_weighted": 1.5,
}

# Scenarios whose documented outcome does not hold today, and why (docs say the same): run and
# reported as xfail, never dropped; not strict, since whether they hold depends on the processor.
KNOWN_FAILURES = {
    "hyq_trot_rough": "chaotic: the unperturbed start falls at 21.38 s on this machine kind, "
    "starts perturbed by 1e-9 rad cross the tiles as documented (docs/locomotion.md)",
}


def _cost(path: Path) -> float:
    if path.stem in WALL_S:
        return WALL_S[path.stem]
    return NEW_SCENARIO_S_PER_SIM_S * tomllib.loads(path.read_text())["duration"]


def groups() -> list[list[Path]]:
    """Every shipped scenario in exactly one of GROUPS groups, longest first into the group with
    the least wall time so far (sorted by name within a group)."""
    paths = sorted(SCENARIOS.glob("*.toml"), key=lambda p: (-_cost(p), p.stem))
    loads, members = [0.0] * GROUPS, [[] for _ in range(GROUPS)]
    for path in paths:
        k = loads.index(min(loads))
        loads[k] += _cost(path)
        members[k].append(path)
    return [sorted(group) for group in members]


def group(k: int) -> list:
    """The scenarios of group `k` (1 … GROUPS) as pytest parameters, named by scenario; those in
    KNOWN_FAILURES marked xfail with the reason."""
    return [
        pytest.param(
            path,
            id=path.stem,
            marks=[pytest.mark.xfail(reason=KNOWN_FAILURES[path.stem], strict=False)]
            if path.stem in KNOWN_FAILURES
            else [],
        )
        for path in groups()[k - 1]
    ]


def run_and_check(path: Path) -> None:
    """Run `path` to its end; its [expect] must be checked and hold, and every number the run
    reports must be one an [expect] table may name (METRIC_KEYS)."""
    scenario = load_scenario(path)
    report = run_scenario(scenario)
    section = report["expect"]
    assert section["checked"], section.get("note")
    assert section["passed"], f"{path.name}: " + "; ".join(failed_checks(section))
    assert report["sim_time_s"] <= scenario.duration + 1e-6
    if not report["fell"]:
        assert math.isclose(report["sim_time_s"], scenario.duration, abs_tol=2e-3)
    patterns = [re.compile(k) for name in scenario.metrics for k in METRIC_KEYS[name]]
    unknown = [k for k in report["metrics"] if not any(p.fullmatch(k) for p in patterns)]
    assert not unknown, f"metrics reported but not in expect.METRIC_KEYS: {unknown}"
    assert all(field in report for field in REPORT_FIELDS)
