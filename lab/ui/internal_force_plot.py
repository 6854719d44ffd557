"""The live internal-force chart (Kim 2016 §IV): between two point feet in support, the
reference F_int,ref, the sensed F_int (eq. 13 or the contact forces) and the command of eq. 12,
from telemetry's `internal_force`. It shows while the `internal_force` task is in the stack;
with a foot in the air the sensed value and the command are gaps."""

import contextlib
import math

import viser

from lab.ui.plots import Atomic, Chart, ChartSpec, Container

LABELS = ("reference", "sensed", "command (eq. 12)")


def _running(tel: dict) -> bool:
    return any("internal_force" in level for level in tel["stack"])


def internal_force_labels(tel: dict) -> tuple[str, ...]:
    """The series while the task runs, none otherwise (the chart then hides)."""
    return LABELS if _running(tel) else ()


def internal_force_values(tel: dict) -> list[float]:
    """[reference, sensed, command] (N) of one telemetry message; NaN with no pair in support."""
    report = tel["internal_force"]
    sensed, command = report["sensed"], report["command"]
    return [
        report["reference"],
        sensed[0] if sensed else math.nan,
        command[0] if command else math.nan,
    ]


INTERNAL_FORCE = ChartSpec(
    "Internal force between the feet [N]", internal_force_labels, internal_force_values
)


def add_internal_force_plot(
    gui: viser.GuiApi, folder: Container, atomic: Atomic = contextlib.nullcontext
) -> Chart:
    """The chart in `folder` (a folder or tab) of `gui` (`atomic`: the server's); feed it with
    `record(telemetry)`, show with `draw`."""
    return Chart(gui, folder, INTERNAL_FORCE, atomic)
