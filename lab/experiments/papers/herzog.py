"""Herzog et al. 2016's Table 3 (docs/replications.md): the push campaign in double support on
Talos, the same 28 pushes under the PD momentum law and the two LQR designs."""

from lab.experiments.papers.tables import Column, Reports, Table, paper, value

PD, LQR, LQR_TALOS = "herzog_table3_pd", "herzog_table3_lqr", "herzog_table3_lqr_talos"
LABELS = {PD: "PD", LQR: "LQR", LQR_TALOS: "LQR Talos"}
# The campaign's points, four pushes each at 40, 60, 80 and 100 % (scenarios/herzog_table3_*).
POINTS = ("torso F", "torso R", "torso B", "torso L", "hip F", "hip R", "hip L")
PUSHES_PER_POINT = 4
PUSHES = tuple(range(len(POINTS) * PUSHES_PER_POINT))


def metric(reports: Reports, run: str, push: object, key: str) -> float:
    """Push `push`'s `push<i>_<key>` metric in `run`."""
    return value(reports, run, f"push{push}_{key}")


def push_column(header: str, key: str, fmt: str) -> Column:
    """A property of the push itself, the same in the three runs (read from the PD one)."""
    return Column(header, lambda row, r: format(metric(r, PD, row, key), fmt))


def cog_error(run: str) -> Column:
    """The largest |c − c_ref| (mm) until the next push."""
    return Column(
        f"{LABELS[run]} CoG err (mm)",
        lambda row, r: f"{1e3 * metric(r, run, row, 'max_cog_error_m'):.1f}",
    )


def momentum(run: str) -> Column:
    """The largest |h_lin| (kg m/s) / |h_ang| (kg m²/s) until the next push."""

    def cell(row: object, reports: Reports) -> str:
        linear = metric(reports, run, row, "max_linear_momentum")
        angular = metric(reports, run, row, "max_angular_momentum")
        return f"{linear:.1f} / {angular:.2f}"

    return Column(f"{LABELS[run]} max lin / ang mom.", cell)


def fell(row: object, reports: Reports) -> str:
    return " / ".join("yes" if metric(reports, run, row, "fell") else "no" for run in LABELS)


HERZOG_TABLE3 = Table(
    "herzog_table3",
    PUSHES,
    (
        Column("point", lambda row, _: POINTS[int(str(row)) // PUSHES_PER_POINT]),
        Column("push", lambda row, _: str(int(str(row)) % PUSHES_PER_POINT + 1)),
        push_column("peak (N)", "peak_force_n", ".0f"),
        push_column("impulse (N s)", "impulse_ns", ".1f"),
        *(cog_error(run) for run in LABELS),
        *(momentum(run) for run in LABELS),
        Column("fell " + " / ".join(LABELS.values()), fell),
    ),
    runs=tuple(LABELS),
)

HERZOG = paper("herzog", HERZOG_TABLE3)
