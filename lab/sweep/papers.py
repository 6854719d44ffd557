"""The generated tables of docs/replications.md: per paper, the scenarios it runs and each
table's columns, the measured ones read from the runs' reports beside the paper's numbers.

A table has row ids (a scenario's name, or a push's index for Herzog's Table 3) and columns;
a column's cell is computed from the row id and the reports of the paper's runs (flattened
as in a sweep table: `metrics.<key>`, `fell`, `sim_time_s`, ...). `lab report PAPER` runs the
scenarios and writes each table between its markers (report.py).
"""

from collections.abc import Callable, Mapping
from dataclasses import dataclass

Reports = Mapping[str, Mapping[str, object]]  # scenario name -> flattened report


@dataclass(frozen=True)
class Column:
    """A table column: its header and the text of its cell for a row id."""

    header: str
    cell: Callable[[object, Reports], str]


@dataclass(frozen=True)
class Table:
    """One generated table: its marker name in the docs, row ids, columns."""

    name: str
    rows: tuple[object, ...]
    columns: tuple[Column, ...]


@dataclass(frozen=True)
class Paper:
    """A paper's replication: the scenarios `lab report` runs and the tables they fill."""

    name: str
    scenarios: tuple[str, ...]
    tables: tuple[Table, ...]


def value(reports: Reports, scenario: str, key: str) -> float:
    """A number of a scenario's report (`metrics.` is prepended unless `key` is top-level)."""
    report = reports[scenario]
    return float(report[key] if key in report else report[f"metrics.{key}"])


def name_column(header: str = "run") -> Column:
    return Column(header, lambda row, _: f"`{row}`")


def given(header: str, texts: Mapping[object, str]) -> Column:
    """Text fixed per row: a description, or the paper's numbers."""
    return Column(header, lambda row, _: texts[row])


def measured(header: str, key: str, fmt: str, scale: float = 1.0, paper: dict | None = None):
    """`key` of the row's scenario times `scale` in `fmt`, and the paper's number in brackets."""

    def cell(row: object, reports: Reports) -> str:
        text = format(scale * value(reports, str(row), key), fmt)
        return f"{text} ({paper[row]})" if paper else text

    return Column(header, cell)


def fell_column(header: str = "fell") -> Column:
    def cell(row: object, reports: Reports) -> str:
        report = reports[str(row)]
        return f"at {float(report['sim_time_s']):.2f} s" if report["fell"] else "no"

    return Column(header, cell)


def thousands(x: float) -> str:
    """29358.4 -> '29 358' (the docs' grouping)."""
    return f"{x:,.0f}".replace(",", " ")


HUTTER_LOAD = ("tau_min", "force_min", "tau_lim_tau_min", "tau_lim_force_min")
HUTTER_LOAD = tuple(f"hutter_sim{i}_{n}" for i, n in enumerate(HUTTER_LOAD, start=1))


def per_load_run(*texts: str) -> dict[str, str]:
    """Texts for the four runs of Table 5, in order."""
    return dict(zip(HUTTER_LOAD, texts, strict=True))


TABLE5_ENERGY = per_load_run("3 985", "5 730", "4 034", "5 502")  # the paper's E_τ
TABLE5_FRICTION = per_load_run("0.27", "0.04", "0.29", "0.10")  # the paper's μ̄
HUTTER_TABLE5 = Table(
    "hutter_table5",
    HUTTER_LOAD,
    (
        name_column(),
        given("step 2", per_load_run("τ min", "F min", "τ lim, τ min", "τ lim, F min")),
        Column(
            "E_τ [N²m²s] (paper)",
            lambda row, r: (
                thousands(value(r, row, "energy_tau_n2m2s")) + f" ({TABLE5_ENERGY[row]})"
            ),
        ),
        Column(
            "μ̄ (paper)",
            lambda row, r: (
                f"{value(r, row, 'mean_friction_ratio'):.3f} "
                f"[{value(r, row, 'mean_friction_ratio_measured'):.3f}] "
                f"({TABLE5_FRICTION[row]})"
            ),
        ),
        measured(
            "max τ_KFE [N m] (paper)",
            "max_knee_torque_nm",
            ".1f",
            paper=per_load_run("12.2", "16.0", "10.0", "10.0"),
        ),
    ),
)
HUTTER_SIM5 = Table(
    "hutter_sim5",
    ("hutter_sim5_knee_limited", "hutter_sim5_knee_hip_limited"),
    (
        name_column(),
        given(
            "limits",
            {
                "hutter_sim5_knee_limited": "KFE 14 N m",
                "hutter_sim5_knee_hip_limited": "KFE and HFE 14 N m",
            },
        ),
        Column(
            "max τ_KFE / τ_HFE [N m]",
            lambda row, r: (
                f"{value(r, row, 'max_knee_torque_nm'):.1f} / "
                f"{value(r, row, 'max_hip_torque_nm'):.1f}"
            ),
        ),
        fell_column(),
        measured("RMS height error, last 1 s [mm]", "rms_height_error_last_s_m", ".1f", 1e3),
    ),
)
HUTTER_SIM9 = Table(
    "hutter_sim9",
    ("hutter_sim9_without_interpolation", "hutter_sim9_interpolation"),
    (
        name_column(),
        measured(
            "largest one-tick torque change within 5 ms of a contact switch [N m]",
            "max_torque_step_at_switch_nm",
            ".1f",
        ),
        measured("anywhere [N m]", "max_torque_step_nm", ".1f"),
    ),
)
HUTTER_EXP67 = Table(
    "hutter_exp67",
    ("hutter_exp6_height_lowest", "hutter_exp7_pitch_lowest"),
    (
        name_column(),
        given(
            "lowest priority",
            {"hutter_exp6_height_lowest": "body height", "hutter_exp7_pitch_lowest": "orientation"},
        ),
        measured("HFE past its limit [mrad]", "max_joint_limit_excess_rad", ".1f", 1e3),
        measured("max height error [mm]", "max_height_error_m", ".1f", 1e3),
        measured("max pitch error [rad]", "max_pitch_error_rad", ".3f"),
    ),
)
HUTTER_CYLINDER = Table(
    "hutter_half_cylinder",
    ("hutter_half_cylinder_aligned", "hutter_half_cylinder_vertical"),
    (
        name_column(),
        given(
            "step 2",
            {
                "hutter_half_cylinder_aligned": "τ lim, force_normal, τ min",
                "hutter_half_cylinder_vertical": "τ lim, τ min",
            },
        ),
        fell_column(),
        Column(
            "max / mean foot slip [mm]",
            lambda row, r: (
                f"{1e3 * value(r, row, 'max_foot_slip_m'):.0f} / "
                f"{1e3 * value(r, row, 'mean_foot_slip_m'):.0f}"
            ),
        ),
        Column(
            "μ̄ about the local normal",
            lambda row, r: (
                f"{value(r, row, 'mean_friction_ratio'):.2f} "
                f"[{value(r, row, 'mean_friction_ratio_measured'):.2f}]"
            ),
        ),
    ),
)

HUTTER = Paper(
    "hutter",
    tuple(
        name
        for table in (HUTTER_TABLE5, HUTTER_SIM5, HUTTER_SIM9, HUTTER_EXP67, HUTTER_CYLINDER)
        for name in table.rows
    ),
    (HUTTER_TABLE5, HUTTER_SIM5, HUTTER_SIM9, HUTTER_EXP67, HUTTER_CYLINDER),
)

PAPERS: dict[str, Paper] = {paper.name: paper for paper in (HUTTER,)}
