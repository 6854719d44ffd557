"""Kim et al. 2016's tables (docs/replications.md): Bolt on the split wedges with and without
internal-force feedback (Fig. 6, 7), the CoM ellipse (Fig. 6b), and stepping (Fig. 8, §VI-C).

Forces scale with weight: Hume's 100 N internal force is 0.51 of its weight, 6.27 N on Bolt."""

from lab.experiments.papers.tables import Column, Reports, Table, given, name_column, paper, value

F_INT_100N = 6.27  # N, Hume's 100 N scaled to Bolt's weight (0.51 m g)
F_INT_10N = 0.615  # N, Hume's 10 N scaled likewise (0.05 m g)


def outcome(row: object, reports: Reports) -> str:
    """'stands', or when the run fell, when."""
    report = reports[str(row)]
    return f"falls at {float(report['sim_time_s']):.2f} s" if report["fell"] else "stands"


def internal_force_error(reference: dict[str, float]) -> Column:
    """The measured F_int's error against its reference (Kim eq. 17): mean, max and the max as
    a share of the reference; none when the run fell."""

    def cell(row: object, reports: Reports) -> str:
        name = str(row)
        if reports[name]["fell"]:
            return "—"
        mean = value(reports, name, "internal_force_mean_error_n")
        largest = value(reports, name, "internal_force_max_error_n")
        return f"{mean:+.3f} N, {largest:.3f} N ({100 * largest / reference[name]:.1f} %)"

    return Column("F_int error (mean, max)", cell)


def foot_slide(row: object, reports: Reports) -> str:
    """How far a foot slid: in mm while it holds, in m when it slipped off."""
    slide = value(reports, str(row), "max_foot_slide_m")
    return f"{1e3 * slide:.1f} mm" if slide < 0.1 else f"{slide:.2f} m"


WEDGES = ("kim_wedges_100n", "kim_wedges_100n_open_loop", "kim_wedges_10n")
KIM_WEDGES = Table(
    "kim_wedges",
    WEDGES,
    (
        name_column("scenario"),
        given("F_int,ref", dict(zip(WEDGES, ("6.27 N", "6.27 N", "0.615 N"), strict=True))),
        given("K_F", dict(zip(WEDGES, ("1", "0", "1"), strict=True))),
        Column("outcome", outcome),
        internal_force_error(dict(zip(WEDGES, (F_INT_100N, F_INT_100N, F_INT_10N), strict=True))),
        Column("foot slide", foot_slide),
        given(
            "paper",
            dict(
                zip(
                    WEDGES,
                    ('stands (Fig. 6), "errors small"', "—", "slips and falls (Fig. 7)"),
                    strict=True,
                )
            ),
        ),
    ),
)

STEPPING = ("bolt_step_in_place", "bolt_walk_planner", "bolt_walk_turn")
KIM_STEPPING = Table(
    "kim_stepping",
    STEPPING,
    (
        name_column("scenario"),
        Column("duration", lambda row, r: f"{value(r, str(row), 'sim_time_s'):.0f} s"),
        Column("steps", lambda row, r: f"{value(r, str(row), 'steps'):.0f}"),
        Column("falls", lambda row, r: "1" if r[str(row)]["fell"] else "0"),
        Column(
            "CoM height error",
            lambda row, r: f"{1e3 * value(r, str(row), 'max_com_height_error_m'):.1f} mm",
        ),
        Column(
            "roll-pitch error",
            lambda row, r: f"{value(r, str(row), 'max_roll_pitch_error_rad'):.3f} rad",
        ),
        Column("turned", lambda row, r: f"{value(r, str(row), 'yaw_turned_rad'):.1f} rad"),
        given(
            "paper",
            dict(
                zip(
                    STEPPING,
                    (
                        "≥ 20 steps asked; Fig. 8d: 2 cm, 0.15 rad",
                        "Hume walked 22 steps (§VI-C)",
                        "the lab's steering: 0.3 m/s at 0.3 rad/s",
                    ),
                    strict=True,
                )
            ),
        ),
    ),
)

ELLIPSE = ("kim_wedges_ellipse", "kim_wedges_ellipse_open_loop")
KIM_ELLIPSE = Table(
    "kim_ellipse",
    ELLIPSE,
    (
        name_column("scenario"),
        given("K_F", dict(zip(ELLIPSE, ("1", "0"), strict=True))),
        Column("outcome", outcome),
        Column(
            "CoM error max (RMS)",
            lambda row, r: (
                f"{1e3 * value(r, str(row), 'cog_error_max_m'):.2f} mm "
                f"({1e3 * value(r, str(row), 'cog_error_rms_m'):.2f} mm)"
            ),
        ),
        internal_force_error(dict.fromkeys(ELLIPSE, F_INT_100N)),
        Column("foot slide", foot_slide),
    ),
)

KIM = paper("kim", KIM_WEDGES, KIM_ELLIPSE, KIM_STEPPING)
