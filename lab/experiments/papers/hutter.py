"""Hutter et al. 2014's tables (docs/replications.md, §5.1): static walking, load distribution,
torque limits, contact-force interpolation, the HFE limit and the half-cylinder walk."""

from lab.experiments.papers.tables import (
    Column,
    Table,
    fell_column,
    given,
    measured,
    name_column,
    paper,
    thousands,
    value,
)

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
            published=per_load_run("12.2", "16.0", "10.0", "10.0"),
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

HUTTER = paper("hutter", HUTTER_TABLE5, HUTTER_SIM5, HUTTER_SIM9, HUTTER_EXP67, HUTTER_CYLINDER)
