"""Export what the plots show: CSV for numbers, PNG for a figure (matplotlib's Agg canvas, no
pyplot: no global state, safe on the UI's worker threads)."""

import io
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

PNG_DPI = 100
PANEL_SIZE_IN = (7.0, 2.2)  # width, height of one chart in the figure


class Shown(NamedTuple):
    """One chart as shown: its title, series labels and (t, series…) arrays."""

    title: str
    labels: Sequence[str]
    data: Sequence[np.ndarray]


def shown_csv(charts: Sequence[Shown]) -> str:
    """CSV of what charts show: one row per sample time of any chart, a column "t [s]" and one
    per series named "<chart title>: <series>" (empty where that chart has no sample); a chart
    with nothing shown, or no time axis (a phase portrait), has no columns."""
    columns = [
        f"{title}: {label}" for title, labels, data in charts if len(data) for label in labels
    ]
    rows: dict[float, dict[str, float]] = {}
    for title, labels, data in charts:
        if len(data) == 0:
            continue
        for i, t in enumerate(data[0]):
            row = rows.setdefault(float(t), {})
            for label, series in zip(labels, data[1:], strict=True):
                row[f"{title}: {label}"] = float(series[i])
    out = io.StringIO()
    out.write(",".join(f'"{c}"' for c in ["t [s]", *columns]) + "\n")
    for t in sorted(rows):
        values = [repr(rows[t][c]) if c in rows[t] else "" for c in columns]
        out.write(",".join([repr(t), *values]) + "\n")
    return out.getvalue()


def shown_png(charts: Sequence[Shown]) -> bytes:
    """A PNG with one panel per chart that has data, on a shared time axis, series as in the
    page (the CoP chart's support-polygon bounds dashed)."""
    drawn = [c for c in charts if len(c.data) and len(c.data[0])]
    rows = max(1, len(drawn))
    figure = Figure(figsize=(PANEL_SIZE_IN[0], PANEL_SIZE_IN[1] * rows), dpi=PNG_DPI)
    canvas = FigureCanvasAgg(figure)
    axes = figure.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    if not drawn:
        axes[0].text(0.5, 0.5, "nothing plotted yet", ha="center", va="center")
    for ax, chart in zip(axes, drawn, strict=False):
        t = chart.data[0]
        for i, (label, series) in enumerate(zip(chart.labels, chart.data[1:], strict=True)):
            bound = chart.title.startswith("CoP") and i >= 2
            ax.plot(t, series, label=label, lw=0.8 if bound else 1.2, ls="--" if bound else "-")
        ax.set_title(chart.title, fontsize=9, loc="left")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", ncol=min(4, max(1, len(chart.labels))))
    axes[-1].set_xlabel("t [s]")
    figure.tight_layout()
    out = io.BytesIO()
    canvas.print_png(out)
    return out.getvalue()
