"""The live Kim 2016 plots: the internal force and the CoM phase portraits, fed from a
stepping Bolt's telemetry into a real viser GUI (no browser)."""

import math

import numpy as np
import viser

from lab.ui.internal_force_plot import (
    add_internal_force_plot,
    internal_force_labels,
    internal_force_values,
)
from lab.ui.phase_portrait_plot import add_phase_portrait_plot, portrait_points
from lab.ui.plot_range import axis_range
from lab.world.session import Session, SessionConfig
from tests.helpers.ports import free_port


def test_portrait_points_are_sorted_by_position_each_velocity_where_it_belongs() -> None:
    path = np.array([[0.03, 0.1], [0.01, -0.2]])
    prediction = np.array([[0.02, 0.0], [-0.01, 0.3]])
    x, on_path, predicted = portrait_points(path, prediction)
    assert x.tolist() == [-0.01, 0.01, 0.02, 0.03]
    assert np.isnan(on_path[[0, 2]]).all() and on_path[[1, 3]].tolist() == [-0.2, 0.1]
    assert np.isnan(predicted[[1, 3]]).all() and predicted[[0, 2]].tolist() == [0.3, 0.0]


def test_the_y_range_spans_the_finite_values_and_holds_until_they_leave_or_shrink() -> None:
    """uPlot cannot range a series with NaN gaps (plot_range.py): the range comes from the
    finite values, padded, at least min_span wide, and is kept while they fit and fill it."""
    values = np.array([math.nan, -0.12, 0.3, math.nan])
    low, high = axis_range(values, None, 0.1)
    assert low < -0.12 and high > 0.3 and high - low < 2.4 * 0.42 + 1e-9
    assert axis_range(np.array([0.0, 0.25]), (low, high), 0.1) == (low, high)  # fits and fills
    wider = axis_range(np.array([0.0, 0.9]), (low, high), 0.1)
    assert wider[1] > 0.9
    assert axis_range(np.array([0.0, 0.01]), wider, 0.1)[1] < 0.2  # shrinks with the data
    low, high = axis_range(np.array([0.5, 0.5]), None, 0.1)  # all equal: min_span wide around them
    assert low < 0.45 and high > 0.55
    assert axis_range(np.full(3, math.nan), None, 0.1) == (-0.05, 0.05)


def test_stepping_bolts_telemetry_feeds_both_plots() -> None:
    """0.4 s of biped_step: the internal-force chart shows its reference and gaps in the air,
    the portraits show the CoM path and the planner's prediction, within a GUI."""
    session = Session(SessionConfig(robot="bolt"))
    assert session.handle("gait", {"name": "biped_step"})["ok"]
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        folder = server.gui.add_folder("Plots")
        charts = [add_internal_force_plot(server.gui, folder)]
        charts += add_phase_portrait_plot(server.gui, folder)
        messages = []
        while session.time < 0.4:
            session.tick()
            if session.ticks % 10 == 0:
                messages.append(session.telemetry())
                for chart in charts:
                    chart.record(messages[-1])
        for chart in charts:
            chart.draw(10.0)
    finally:
        server.stop()
    tel = messages[-1]
    assert internal_force_labels(tel) and tel["stepping"]["prediction"] is not None
    values = np.array([internal_force_values(m) for m in messages])
    assert np.all(values[:, 0] == 0.0)  # kim_stepping's reference in the brief dual support
    assert np.isnan(values[:, 1]).any() and np.isfinite(values[:, 1]).any()
    force, forward, lateral = charts
    assert force.shown and len(force.shown[0]) == len(messages)
    assert forward.labels == lateral.labels == ("path", "prediction")
    assert forward._handle is not None and lateral._handle is not None
    lateral_com = [m["stepping"]["com"][1] for m in messages[-len(lateral.path) :]]
    x, on_path, predicted = lateral._handle.data
    assert sorted(lateral_com) == [v for v, p in zip(x, on_path, strict=True) if not math.isnan(p)]
    assert np.isfinite(predicted).sum() == len(tel["stepping"]["prediction"]["lateral"])
