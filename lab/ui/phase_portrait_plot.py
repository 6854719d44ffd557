"""Live CoM phase portraits of point-foot stepping (Kim 2016 Figs. 4–5): forward (x, ẋ) and
lateral (y, ẏ) in the heading frame, the CoM's last PATH_S seconds against the planner's last
prediction (over the stance foot to the switch, then over the planned foot for t′), from
telemetry's `stepping`. Shown while `biped_step` runs.

uPlot needs its x values sorted, and a phase portrait's positions are not: each chart is drawn
as points over the positions sorted, one series for the path and one for the prediction (NaN
where the other has a point), with no lines between them. With those NaN gaps uPlot cannot
range the velocity axis itself (`plot_range.py`): the chart is given its y range, and its x
range the same way (uPlot's own spread a lateral path of 3 cm over 0.65 m).
"""

import math

import numpy as np
import viser
import viser.uplot as uplot

from lab.ui.plot_buffer import RollingBuffer
from lab.ui.plot_range import axis_range
from lab.ui.plots import Container

PATH_S = 2.0  # s of the CoM's path shown
BUFFER_SAMPLES = 1024  # > PATH_S at 100 Hz telemetry
AXES = (("forward", "x"), ("lateral", "y"))
COLOURS = ("#d62728", "#1f77b4")  # path, prediction
MIN_SPAN = 0.1  # m/s: the velocity axis spans at least this
MIN_POSITION_SPAN = 0.05  # m: the position axis spans at least this


def portrait_points(path: np.ndarray, prediction: np.ndarray) -> tuple[np.ndarray, ...]:
    """(position, path velocity, predicted velocity) sorted by position, from `path` and
    `prediction` (rows position m, velocity m/s); each velocity NaN at the other's points."""
    x = np.concatenate((path[:, 0], prediction[:, 0]))
    on_path = np.arange(len(x)) < len(path)
    v = np.concatenate((path[:, 1], prediction[:, 1]))
    order = np.argsort(x, kind="stable")
    x, v, on_path = x[order], v[order], on_path[order]
    return x, np.where(on_path, v, math.nan), np.where(on_path, math.nan, v)


class PhasePortrait:
    """One axis's chart; the interface of `plots.Chart` (record, draw, title, labels, shown)."""

    def __init__(self, gui: viser.GuiApi, folder: Container, axis: int) -> None:
        self._gui, self._folder, self.axis = gui, folder, axis
        name, letter = AXES[axis]
        self.title = f"CoM phase portrait, {name} ({letter} [m], {letter}̇ [m/s])"
        self.labels: tuple[str, ...] | None = None
        self.shown: tuple[np.ndarray, ...] = ()  # not exported: no time axis
        self.path = RollingBuffer(2, PATH_S, BUFFER_SAMPLES)
        self.prediction = np.zeros((0, 2))
        self._handle: viser.GuiUplotHandle | None = None
        self._y_range: tuple[float, float] | None = None
        self._x_range: tuple[float, float] | None = None

    def record(self, tel: dict) -> None:
        """Add one telemetry message's CoM state and keep its prediction."""
        stepping = tel.get("stepping")
        if stepping is None:
            if self.labels:
                self.labels, self.prediction = (), np.zeros((0, 2))
                self.path.clear()
                self._hide()
            return
        if not self.labels:  # the first message, or the plots were cleared (`Plots.clear`)
            self.path.clear()
            self.labels = ("path", "prediction")
        a = self.axis
        self.path.append(tel["t"], [stepping["com"][a], stepping["com_velocity"][a]])
        plan = stepping["prediction"]
        if plan is not None:
            rows = np.asarray(plan["forward" if a == 0 else "lateral"], dtype=float)
            self.prediction = rows[:, 1:3].reshape(-1, 2)

    def draw(self, window_s: float) -> None:
        """Redraw (the window is PATH_S whatever the plots' window)."""
        if not self.labels or len(self.path) < 2:
            return
        _, x, v = self.path.arrays()
        data = portrait_points(np.column_stack((x, v)), self.prediction)
        shown = axis_range(np.concatenate(data[1:]), self._y_range, MIN_SPAN)
        shown_x = axis_range(data[0], self._x_range, MIN_POSITION_SPAN)
        scales: dict[str, uplot.Scale] = {
            "x": {"time": False, "auto": False, "range": shown_x},
            "y": {"auto": False, "range": shown},
        }
        if self._handle is None:
            with self._folder:
                self._handle = self._gui.add_uplot(
                    data,
                    _series(self.axis),
                    title=self.title,
                    scales=scales,
                    aspect=1.6,
                    legend={"show": True},
                )
        else:
            if not self._handle.visible:
                self._handle.visible = True
            self._handle.data = data
            if (shown, shown_x) != (self._y_range, self._x_range):
                self._handle.scales = scales  # the chart is not rebuilt, its zoom stays
        self._y_range, self._x_range = shown, shown_x

    def _hide(self) -> None:
        """Hide the chart (kept for the next stepping: removing it logged console errors,
        `plots.Chart`)."""
        if self._handle is not None:
            self._handle.visible = False


def _series(axis: int) -> tuple[uplot.Series, ...]:
    letter = AXES[axis][1]
    out: list[uplot.Series] = [{"label": f"{letter} [m]"}]
    for label, colour in zip(("path", "prediction"), COLOURS, strict=True):
        points = {"show": True, "size": 4, "stroke": colour, "fill": colour}
        out.append({"label": f"{label} {letter}̇", "stroke": "rgba(0,0,0,0)", "points": points})
    return tuple(out)


def add_phase_portrait_plot(gui: viser.GuiApi, folder: Container) -> list[PhasePortrait]:
    """The forward and lateral portraits in `folder` (a folder or tab) of `gui`; feed each with
    `record`."""
    return [PhasePortrait(gui, folder, axis) for axis in range(len(AXES))]
