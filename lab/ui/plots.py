"""Live uPlot charts of telemetry: a rolling window (10, 30 or 60 s), redrawn at the caller's
rate (20-30 Hz) unless paused, the shown window exportable as CSV and PNG (`plot_export`).

Each chart is a `Chart`: a title, a function giving its series labels for the current telemetry
layout (contacts, stack) and one giving the values of one message. When the labels change (robot
switch, stack edit) the chart is rebuilt with fresh buffers. Buffers keep MAX_WINDOW_S whatever
the window shown, so a longer window shows the past at once. While paused, the charts keep what
they show (uPlot's drag-to-zoom then holds: a redraw resets it) and recording goes on.
"""

import contextlib
import math
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass

import numpy as np
import viser
import viser.uplot as uplot

from lab.ui.plot_buffer import RollingBuffer
from lab.ui.plot_export import Shown, shown_csv, shown_png
from lab.ui.plot_range import axis_range
from lab.ui.support import polygon_bounds

WINDOWS_S = (10, 30, 60)  # the windows the panel offers; the first is the default
MAX_WINDOW_S = float(max(WINDOWS_S))
BUFFER_SAMPLES = 8192  # > MAX_WINDOW_S at 100 Hz telemetry
MAX_POINTS = 250  # points per series sent to the browser
TOP_LEVELS = 3  # task errors are plotted for this many highest-priority levels
ERROR_FLOOR = 1e-12  # a task error of 0 plots as 10⁻¹²
Y_AXIS_PX = 64  # room for tick labels such as "12,500"
GAP_SPAN = 0.1  # a chart with NaN gaps spans at least this fraction of its largest |value|
Container = viser.GuiFolderHandle | viser.GuiTabHandle  # where the charts and their controls go
PALETTE = (
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#17becf", "#8c564b", "#e377c2",
)  # fmt: skip


def _labels_forces(tel: dict) -> tuple[str, ...]:
    return tuple(c["name"] for c in tel["contacts"])


def _forces(tel: dict) -> list[float]:
    return [c["measured_force"][2] for c in tel["contacts"]]


def _labels_cop(tel: dict) -> tuple[str, ...]:
    return ("CoP x", "CoP y", "x min", "x max", "y min", "y max")


def _cop(tel: dict) -> list[float]:
    net = tel["cop"]["net"]
    # the bounds of the support polygon are those of its vertices: no hull needed
    pts = np.array([c["position"] for c in tel["contacts"] if c["active"]]).reshape(-1, 3)
    x0, x1, y0, y1 = polygon_bounds(pts)
    cx, cy = (net[0], net[1]) if net is not None else (np.nan, np.nan)
    return [cx, cy, x0, x1, y0, y1]


def _labels_linear(tel: dict) -> tuple[str, ...]:
    return ("px", "py", "pz")


def _linear(tel: dict) -> list[float]:
    return list(tel["momentum"]["linear"])


def _labels_angular(tel: dict) -> tuple[str, ...]:
    return ("Lx", "Ly", "Lz")


def _angular(tel: dict) -> list[float]:
    return list(tel["momentum"]["angular"])


def _labels_tasks(tel: dict) -> tuple[str, ...]:
    return tuple(t["name"] for t in tel["tasks"] if t["level"] < TOP_LEVELS)


def _tasks(tel: dict) -> list[float]:
    # Decades: a well-tracked task's error is 1e-7…1e-3 (SI), which uPlot's tick labels (three
    # decimals) would all print as "0"; an error of exactly 0 shows at the floor.
    return [
        math.log10(max(t["error"], ERROR_FLOOR)) for t in tel["tasks"] if t["level"] < TOP_LEVELS
    ]


def _labels_levels(tel: dict) -> tuple[str, ...]:
    solution = tel.get("solution") or {}
    return tuple(f"level {k}" for k in range(len(solution.get("level_us", ()))))


def _levels(tel: dict) -> list[float]:
    return list(tel["solution"]["level_us"])


def _labels_qp(tel: dict) -> tuple[str, ...]:
    return ("solve µs",)


def _qp(tel: dict) -> list[float]:
    return [tel["qp"]["solve_us"]]


@dataclass(frozen=True)
class ChartSpec:
    title: str
    labels_of: Callable[[dict], tuple[str, ...]]
    values_of: Callable[[dict], list[float]]
    # The y axis spans at least [−min_span, min_span]: a standing robot's momentum of a few
    # 1e-3 would otherwise fill the chart with noise, and uPlot's tick labels (3 decimals) would
    # all read "0".
    min_span: float = 0.0


CHARTS = (
    ChartSpec("Contact normal force [N]", _labels_forces, _forces),
    ChartSpec("CoP vs support polygon [m]", _labels_cop, _cop),
    ChartSpec("Linear momentum [kg m/s]", _labels_linear, _linear, min_span=1.0),
    ChartSpec("Angular momentum [kg m²/s]", _labels_angular, _angular, min_span=0.5),
    ChartSpec("Task errors, top levels [log₁₀ SI]", _labels_tasks, _tasks),
    ChartSpec("QP solve time [µs]", _labels_qp, _qp),
    ChartSpec("Solve time per level [µs]", _labels_levels, _levels),
)


def window_points(data: tuple[np.ndarray, ...], max_points: int) -> tuple[np.ndarray, ...]:
    """What a chart is sent for `data` (t, series…; sorted): times as seconds before the newest
    sample, at most `max_points` per series, the newest kept."""
    t = data[0]
    index = np.arange(len(t) - 1, -1, -max(1, -(-len(t) // max_points)))[::-1]
    return (t[index] - t[-1], *(series[index] for series in data[1:]))


def _series(labels: tuple[str, ...], title: str) -> tuple[uplot.Series, ...]:
    out: list[uplot.Series] = [{"label": "t − t_now [s]"}]
    for i, label in enumerate(labels):
        s: uplot.Series = {"label": label, "stroke": PALETTE[i % len(PALETTE)], "width": 1.5}
        if title.startswith("CoP") and i >= 2:  # polygon bounds: thin dashed, x grey, y blue
            s = {"label": label, "stroke": "#999" if i < 4 else "#9bd", "width": 1, "dash": [4, 4]}
        out.append(s)
    return tuple(out)


Atomic = Callable[[], AbstractContextManager]  # messages sent inside are applied together


class Chart:
    """One live chart. Its uPlot element is made once and kept: new series (robot switch,
    stack edit) replace its series and data in one atomic update, and a chart with nothing to
    show is hidden. Viser's client applies a websocket batch's GUI updates after the batch's
    removals: a chart removed and added anew logged "Tried to update non-existent component"
    whenever a data update of the old one was in the same batch as its removal."""

    def __init__(
        self,
        gui: viser.GuiApi,
        container: Container,
        spec: ChartSpec,
        atomic: Atomic = contextlib.nullcontext,
    ) -> None:
        self._gui = gui
        self._atomic = atomic
        self._container = container
        self.spec = spec
        self.title = spec.title
        self.labels: tuple[str, ...] | None = None
        self.buffer: RollingBuffer | None = None
        self.shown: tuple[np.ndarray, ...] = ()  # (t, series…) last drawn, full resolution
        self._handle: viser.GuiUplotHandle | None = None
        self._relabelled = False  # the handle shows series other than `labels`
        self._sent_scales: dict[str, uplot.Scale] = {}

    def record(self, tel: dict) -> None:
        labels = self.spec.labels_of(tel)
        if labels != self.labels:
            self.labels = labels
            self.buffer = RollingBuffer(len(labels), MAX_WINDOW_S, BUFFER_SAMPLES)
            self.shown = ()
            self._relabelled = self._handle is not None
        if labels:
            self.buffer.append(tel["t"], self.spec.values_of(tel))

    def draw(self, window_s: float) -> None:
        """Show the last `window_s` of data (at most MAX_POINTS points per series)."""
        if not self.labels and self._handle is not None and self._handle.visible:
            self._handle.visible = False  # nothing to show (e.g. its task left the stack)
        if self.buffer is None or not self.labels or len(self.buffer) < 2:
            return
        data = self.buffer.arrays()
        first = np.searchsorted(data[0], data[0][-1] - window_s, side="right")
        self.shown = tuple(a[first:] for a in data)  # full resolution: what an export writes
        data = window_points(self.shown, MAX_POINTS)
        scales = self._scales(data, window_s)
        if self._handle is None:
            with self._container:
                self._handle = self._add(data, scales)
        elif self._relabelled:
            with self._atomic():  # series, data and scales of one count, applied together
                self._handle.series = _series(self.labels, self.title)
                self._handle.data = data
                self._handle.scales = scales
                self._handle.visible = True
            self._relabelled = False
        else:
            self._handle.data = data
            if scales != self._sent_scales:
                self._handle.scales = scales
        self._sent_scales = scales

    def _scales(self, data: tuple[np.ndarray, ...], window_s: float) -> dict[str, uplot.Scale]:
        """uPlot's scales for `data`: x fixed at [-window_s, 0] (seconds before the newest
        sample), y computed here (`plot_range.py`; uPlot's own range of a series with a NaN gap
        is NaN, and the chart empty), at least ±`min_span` and GAP_SPAN of the largest |value|.

        With absolute times on a free x axis, viser's client kept the axis by its position
        relative to the data's extent, recomputed at every update from the axis last committed;
        under load it read an axis not yet committed and the error added up (an axis 35 s behind
        the data, -10,530 s after a Reset, or none). A fixed x range is pinned by the client and
        never recomputed; it changes with the window only."""
        values = np.concatenate(data[1:])
        finite = np.abs(values[np.isfinite(values)])
        floor = GAP_SPAN * float(finite.max()) if finite.size else 1.0
        shown = self._sent_scales.get("y", {}).get("range")
        current = shown if isinstance(shown, tuple) else None
        shown = axis_range(values, current, max(2.0 * self.spec.min_span, floor, 1e-9))
        return {
            "x": {"time": False, "auto": False, "range": (-window_s, 0.0)},
            "y": {"auto": False, "range": shown},
        }

    def _add(
        self, data: tuple[np.ndarray, ...], scales: dict[str, uplot.Scale]
    ) -> viser.GuiUplotHandle:
        return self._gui.add_uplot(
            data,
            _series(self.labels, self.title),
            title=self.title,
            scales=scales,
            axes=({}, {"size": Y_AXIS_PX}),
            aspect=1.6,
            legend={"show": True},
        )


class Plots:
    """The charts with their controls: pause, window length, CSV export of what is shown."""

    def __init__(
        self,
        gui: viser.GuiApi,
        container: Container,
        guard: Callable = lambda f: f,
        atomic: Atomic = contextlib.nullcontext,
    ) -> None:
        with container:
            self.paused = gui.add_checkbox(
                "Pause plots", False, hint="freeze the charts (recording goes on); drag to zoom"
            )
            self.window = gui.add_dropdown(
                "Window [s]", tuple(str(w) for w in WINDOWS_S), initial_value=str(WINDOWS_S[0])
            )
            csv = gui.add_button("Export CSV", hint="the shown window of every chart, as numbers")
            png = gui.add_button("Export PNG", hint="the shown window of every chart, as a figure")
        csv.on_click(guard(self._export_csv))
        png.on_click(guard(self._export_png))
        self.charts = [Chart(gui, container, spec, atomic) for spec in CHARTS]

    def record(self, tel: dict) -> None:
        for chart in self.charts:
            chart.record(tel)

    def clear(self) -> None:
        """Forget every chart's data (another lab is shown: its clock is not this one's)."""
        for chart in self.charts:
            chart.labels = None  # the next message rebuilds the chart with an empty buffer

    def draw(self) -> None:
        if self.paused.value:
            return
        for chart in self.charts:
            chart.draw(float(self.window.value))

    def shown(self) -> list[Shown]:
        """What each chart shows now, at full resolution."""
        return [Shown(c.title, c.labels or (), c.shown) for c in self.charts]

    def csv(self) -> str:
        """What the charts show, as CSV (`shown_csv`)."""
        return shown_csv(self.shown())

    def _export_csv(self, event: viser.GuiEvent) -> None:
        text = self.csv()
        rows = max(0, text.count("\n") - 1)
        self._deliver(event, "lab-plots.csv", text.encode(), f"{rows} rows of what the charts show")

    def _export_png(self, event: viser.GuiEvent) -> None:
        drawn = sum(1 for shown in self.shown() if len(shown.data) and len(shown.data[0]))
        self._deliver(event, "lab-plots.png", shown_png(self.shown()), f"{drawn} charts")

    @staticmethod
    def _deliver(event: viser.GuiEvent, name: str, content: bytes, what: str) -> None:
        """Download `content` as `name` in the browser that asked, and say so there. (Without
        `save_immediately` viser only offers a link in a notification: nothing arrived.)"""
        if event.client is None:
            return
        event.client.send_file_download(name, content, save_immediately=True)
        event.client.add_notification(
            f"Exported {name}",
            f"{what}, {len(content) / 1024:.0f} kB: saved by the browser",
            auto_close_seconds=6.0,
            with_close_button=True,
        )
