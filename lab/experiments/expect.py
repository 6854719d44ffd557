"""A scenario's `[expect]` table: the outcome it must show, checked after `lab run`.

Every shipped scenario states what its run must show, so that no documented outcome goes
unchecked (the suite runs them all, tests/test_scenario_runs_*.py):

    [expect]
    fell = false                                  # the run ends standing (true: it must fall)
    distance_m = { min = 9.0 }                    # a metric of the report, bounded below
    max_base_height_error_m = { max = 0.005 }     # ... above
    internal_force_mean_error_n = { min = 0.05, max = 0.15 }
    qp_failures = { max = 0 }                     # a top-level field of the report

A bound names a key of the report's `metrics` (of the metrics the scenario lists, checked when
the scenario loads) or one of REPORT_FIELDS. After a run the report gains an `expect` section:
each check with its bound, the value and whether it passed; a run cut short (`--duration`) is
not checked, since a whole-run expectation says nothing about a part of the run.
"""

import math
import re
from dataclasses import asdict, dataclass
from pathlib import Path

# The report's own numbers a scenario may bound besides its metrics.
REPORT_FIELDS = ("qp_failures", "divergences", "sim_time_s")

# The keys each metric reports (tests/experiments/test_expect.py holds them to the metrics'
# results);
# `\d+` and `.+` stand for the numbered pushes and the scene's scripted joints.
METRIC_KEYS: dict[str, tuple[str, ...]] = {
    "standing": (
        "max_base_orientation_error_rad",
        "max_base_height_error_m",
        "peak_contact_normal_force_n",
    ),
    "locomotion": (
        "distance_m",
        "mean_velocity_error_mps",
        "mean_velocity_drift_mps",
        "mean_vx_mps",
        "mean_vy_mps",
        "mean_yaw_rate_radps",
        "mean_abs_roll_rad",
        "mean_abs_pitch_rad",
        "largest_push_survived_ns",
    ),
    "pushes": (
        r"push\d+_peak_force_n",
        r"push\d+_impulse_ns",
        r"push\d+_max_cog_error_m",
        r"push\d+_max_linear_momentum",
        r"push\d+_max_angular_momentum",
        r"push\d+_fell",
        "pushes_max_cog_error_m",
        "pushes_fell",
    ),
    "cog_tracking": (
        "cog_error_max_m",
        "cog_error_rms_m",
        "cog_error_z_max_m",
        "cog_error_z_rms_m",
    ),
    "swing_tracking": ("swing_error_max_rad", "swing_error_rms_rad", "swing_ticks"),
    "hand_tracking": (
        "hand_error_max_m",
        "hand_error_rms_m",
        "hand_error_final_m",
        "hand_rotation_error_max_rad",
        "hand_error_push_max_m",  # with pushes only
        "hand_recovery_s",
    ),
    "cop_binding": ("cop_at_bound_fraction", "max_sole_tilt_rad", "max_sole_rise_m"),
    "sole_cop": (
        "cop_sole_fraction_x_max",
        "cop_sole_fraction_y_max",
        "cop_inside_fraction",
        "cop_at_edge_s",
    ),
    "scene_motion": (r".+_min", r".+_max", "sole_slip_max_m"),
    "estimation": (
        "max_estimate_height_error_m",
        "max_estimate_horizontal_error_m",
        "max_estimate_yaw_error_deg",
        "yaw_drift_deg_per_min",
        "rms_estimate_velocity_error_mps",
    ),
    "load_distribution": (
        "energy_tau_n2m2s",
        "mean_friction_ratio",
        "mean_friction_ratio_measured",
        "max_knee_torque_nm",
        "max_hip_torque_nm",
        "max_torque_over_limit_nm",
    ),
    "torque_steps": ("max_torque_step_at_switch_nm", "max_torque_step_nm"),
    "foot_slip": ("max_foot_slip_m", "mean_foot_slip_m"),
    "body_tracking": (
        "max_height_error_m",
        "rms_height_error_last_s_m",
        "max_pitch_error_rad",
        "rms_pitch_error_last_s_rad",
        "max_abs_hfe_rad",
        "max_joint_limit_excess_rad",
    ),
    "internal_force": (
        "internal_force_mean_error_n",
        "internal_force_rms_error_n",
        "internal_force_max_error_n",
        "max_foot_slide_m",
    ),
    "stepping": (
        "steps",
        "stepping_s",
        "swings_cut",
        "swings_lengthened",
        "max_com_height_error_m",
        "max_base_height_error_m",
        "max_roll_pitch_error_rad",
        "max_com_wander_m",
        "com_travel_x_m",
        "com_travel_y_m",
        "com_path_m",
        "yaw_turned_rad",
    ),
}


class ExpectError(ValueError):
    """An `[expect]` table that is malformed or bounds a number the run does not report."""


@dataclass(frozen=True)
class Bound:
    """`name` must lie in [minimum, maximum] (either side may be open: None)."""

    name: str
    minimum: float | None = None
    maximum: float | None = None


@dataclass(frozen=True)
class Expectation:
    """A scenario's expected outcome: whether it falls (None: not stated) and its bounds."""

    fell: bool | None
    bounds: tuple[Bound, ...]


@dataclass(frozen=True)
class Check:
    """One checked expectation: the name, the bound (`expected` for `fell`), the value seen."""

    name: str
    passed: bool
    value: float | bool | None
    expected: bool | None = None
    min: float | None = None
    max: float | None = None


def parse_expect(raw: object, metrics: tuple[str, ...], where: Path | str) -> Expectation:
    """Check an `[expect]` table against the metrics the scenario reports (`where` names the
    file in errors)."""
    if not isinstance(raw, dict):
        raise ExpectError(f"{where}: [expect] must be a table")
    fell = raw.get("fell")
    if fell is not None and not isinstance(fell, bool):
        raise ExpectError(f"{where}: [expect] fell must be true or false, got {fell!r}")
    patterns = [re.compile(key) for name in metrics for key in METRIC_KEYS.get(name, ())]
    bounds = []
    for name, bound in raw.items():
        if name == "fell":
            continue
        if name not in REPORT_FIELDS and not any(p.fullmatch(name) for p in patterns):
            raise ExpectError(
                f"{where}: [expect] {name!r} is not a number this scenario reports: a key of its "
                f"metrics ({', '.join(metrics)}) or one of {', '.join(REPORT_FIELDS)}"
            )
        bounds.append(_bound(name, bound, where))
    if fell is None and not bounds:
        raise ExpectError(f"{where}: [expect] is empty: state fell and/or bounds")
    return Expectation(fell, tuple(bounds))


def _bound(name: str, bound: object, where: Path | str) -> Bound:
    """`{ min = …, max = … }` (either optional; finite numbers, min <= max)."""
    if not isinstance(bound, dict) or not bound or set(bound) - {"min", "max"}:
        raise ExpectError(f"{where}: [expect] {name} must be {{ min = …, max = … }}, got {bound!r}")
    for side, value in bound.items():
        number = isinstance(value, int | float) and not isinstance(value, bool)
        if not number or not math.isfinite(value):
            raise ExpectError(f"{where}: [expect] {name}.{side} must be a finite number")
    low, high = bound.get("min"), bound.get("max")
    if low is not None and high is not None and low > high:
        raise ExpectError(f"{where}: [expect] {name}: min {low} is above max {high}")
    return Bound(name, low, high)


def check_expect(expectation: Expectation, report: dict) -> dict:
    """The report's `expect` section: every check, and whether all passed."""
    checks = []
    if expectation.fell is not None:
        fell = bool(report["fell"])
        checks.append(Check("fell", fell == expectation.fell, fell, expected=expectation.fell))
    for bound in expectation.bounds:
        value = report["metrics"].get(bound.name, report.get(bound.name))
        value = None if value is None else float(value)
        ok = value is not None and math.isfinite(value)
        ok = ok and (bound.minimum is None or value >= bound.minimum)
        ok = ok and (bound.maximum is None or value <= bound.maximum)
        checks.append(Check(bound.name, ok, value, min=bound.minimum, max=bound.maximum))
    return {
        "checked": True,
        "passed": all(c.passed for c in checks),
        "checks": [asdict(c) for c in checks],
    }


def skipped_expect(reason: str) -> dict:
    """The report's `expect` section of a run whose expectation was not checked."""
    return {"checked": False, "passed": None, "checks": [], "note": reason}


def failed_checks(section: dict) -> list[str]:
    """What failed, one line each: `distance_m = 8.1, expected min 9`."""
    lines = []
    for check in section["checks"]:
        if check["passed"]:
            continue
        if check["name"] == "fell":
            lines.append(f"fell = {check['value']}, expected {check['expected']}")
            continue
        sides = [f"{side} {check[side]:g}" for side in ("min", "max") if check[side] is not None]
        lines.append(f"{check['name']} = {check['value']}, expected {' and '.join(sides)}")
    return lines
