"""Plots of sweep tables, drawn with matplotlib into a PNG.

The push-recovery map: one polar panel per hierarchy method, a point per push (angle = push
direction, radius = push force), a filled disc when the robot survived it (coloured by the
largest CoG error, the `cog_tracking` metric), a cross when it fell, a grey square when the
point failed to run.

The robustness map of a bisecting sweep: one panel per bisected field, a row per series (its
method), a bar up to the largest value that succeeded, a disc at every run that succeeded, a
cross at every run that failed.
"""

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.colors import LogNorm

from lab.experiments.sweep.spec import Sweep, succeeded
from lab.experiments.sweep.table import ERROR
from lab.protocol.realism import KNOBS

if TYPE_CHECKING:
    from matplotlib.figure import Figure

FORCE, DIRECTION = "push.force_n", "push.direction_deg"
COM_ERROR = "metrics.cog_error_max_m"
METHOD_COLUMNS = ("controller.method", "method")  # the swept field, else the report's
COLOUR_FLOOR = 1e-4  # m, the smallest CoG error the log colour scale shows


class PlotError(ValueError):
    """A table that cannot be drawn as a push-recovery map; the message says what is missing."""


def plot_push_map(rows: list[dict[str, object]], png: str | Path, title: str) -> Path:
    """Draw `rows` (a sweep table over push.force_n and push.direction_deg) into `png`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    missing = [c for c in (FORCE, DIRECTION) if not any(c in row for row in rows)]
    if missing:
        raise PlotError(f"a push-recovery map needs the swept fields {missing}")
    method = next((c for c in METHOD_COLUMNS if any(c in row for row in rows)), None)
    groups: dict[str, list[dict]] = {}
    for row in rows:
        groups.setdefault(str(row.get(method, "?")), []).append(row)
    survived = [r for r in rows if not r[ERROR] and r.get("fell") is False and COM_ERROR in r]
    errors = [float(r[COM_ERROR]) for r in survived]
    # A log scale: errors of a few mm and a near-fall's metre both stay readable.
    norm = LogNorm(max(min(errors, default=1.0), COLOUR_FLOOR), max(errors, default=1.0))
    forces = sorted({float(r[FORCE]) for r in rows if FORCE in r})
    fig, axes = plt.subplots(
        1,
        len(groups),
        subplot_kw={"projection": "polar"},
        figsize=(3.6 * len(groups) + 1.2, 4.2),
        layout="constrained",
    )
    axes = np.atleast_1d(axes)
    disc = None
    for ax, (name, group) in zip(axes, groups.items(), strict=True):
        disc = _panel(ax, name, group, norm, forces) or disc
    if disc is not None:
        fig.colorbar(disc, ax=list(axes), shrink=0.7, label="max CoG error (m)")
    fig.suptitle(f"{title}: ● survived, × fell, ■ did not run; angle = push direction, radius = N")
    return _save(fig, png)


def _save(fig: "Figure", png: str | Path) -> Path:
    """Write `fig` to `png` (its folder made) and close it."""
    import matplotlib.pyplot as plt  # imported already by the caller (Agg chosen there)

    png = Path(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=100)
    plt.close(fig)
    return png


def _panel(ax: object, name: str, group: list[dict], norm: object, forces: list[float]) -> object:
    """One method's points on polar axes `ax`; the coloured scatter, for the colour bar."""
    ran = [r for r in group if not r[ERROR]]
    kept = [r for r in ran if r.get("fell") is False]
    fell = [r for r in ran if r.get("fell") is not False]
    failed = [r for r in group if r[ERROR]]

    def polar(points: list[dict]) -> tuple[np.ndarray, np.ndarray]:
        return np.radians([float(r[DIRECTION]) for r in points]), [float(r[FORCE]) for r in points]

    disc = None
    if kept:
        colour = [float(r.get(COM_ERROR, np.nan)) for r in kept]
        disc = ax.scatter(*polar(kept), c=colour, cmap="viridis", norm=norm, s=45)
    if fell:
        ax.scatter(*polar(fell), marker="x", color="crimson", s=60, linewidths=2)
    if failed:
        ax.scatter(*polar(failed), marker="s", color="grey", s=40)
    ax.set_ylim(0.0, 1.1 * forces[-1])
    ax.set_yticks(forces, [f"{f:g}" for f in forces], fontsize=7)
    ax.set_rlabel_position(22.5)
    ax.set_title(f"{name}: survived {len(kept)} of {len(group)}", pad=12)
    return disc


def plot_robustness(sweep: Sweep, rows: list[dict[str, object]], png: str | Path) -> Path:
    """Draw a bisecting sweep's table `rows` into `png`: per bisected field, per series, the
    largest value at which the run succeeded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not sweep.series:
        raise PlotError("a robustness map needs a sweep with [bisect]")
    axes_by_field = {series.axis.field: series.axis for series in sweep.series}
    fig, panels = plt.subplots(
        1, len(axes_by_field), figsize=(4.2 * len(axes_by_field), 3.2), layout="constrained"
    )
    for panel, (name, axis) in zip(np.atleast_1d(panels), axes_by_field.items(), strict=True):
        group = [series for series in sweep.series if series.axis.field == name]
        labels = []
        for y, series in enumerate(group):
            state, ran = series.state(rows)
            labels.append(_series_label(series.fields))
            colour = "tab:green" if state.next is None else "lightgrey"  # grey: unfinished
            panel.barh(y, state.largest_ok - axis.lo, left=axis.lo, color=colour, alpha=0.35)
            for row in ran:
                value = float(row[name])
                if succeeded(row):
                    panel.scatter(value, y, marker="o", color="tab:green", s=30, zorder=3)
                else:
                    panel.scatter(value, y, marker="x", color="crimson", s=45, zorder=3)
            panel.annotate(
                f"{state.largest_ok:g}",
                (state.largest_ok, y),
                xytext=(3, 6),
                textcoords="offset points",
                fontsize=8,
            )
        panel.set_yticks(range(len(group)), labels)
        panel.set_xlim(axis.lo, axis.hi * 1.08)
        knob = KNOBS.get(name.removeprefix("realism."))
        unit = f" ({knob.unit})" if knob and knob.unit else ""
        panel.set_xlabel(f"{name.removeprefix('realism.')}{unit}")
        panel.invert_yaxis()
    fig.suptitle(f"{sweep.name}: ● succeeded, × fell or failed; bar: the largest that succeeded")
    return _save(fig, png)


def _series_label(fields: dict[str, object]) -> str:
    """A series' name in the plot: its fields' values (a point's own base by its file's name)."""
    values = [Path(str(v)).stem if k == "base" else str(v) for k, v in fields.items()]
    return "\n".join(values) or "base"
