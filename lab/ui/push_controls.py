"""The panel's "Push" folder: a push of the base in one of four directions of the robot's
heading, its magnitude and duration typed or slid (the numbers sent are the numbers shown).
"""

from __future__ import annotations

import numpy as np
import viser

from lab.ui.number_fields import TypedAt, busy_note, note, show_value
from lab.ui.numbers import NumberError, NumberRange
from lab.ui.panel_host import PanelHost

# Each push button by the way it pushes the robot: its force's unit vector in the heading frame.
# Herzog 2016 (Table 3) and its scenarios name a push by the side the pusher stands on instead:
# pushed "from the front" is the backward push here (docs/ui.md).
PUSH_DIRECTIONS = {
    "forward": (1.0, 0.0),
    "backward": (-1.0, 0.0),
    "left": (0.0, 1.0),
    "right": (0.0, -1.0),
}
PUSH_FORCE_RANGE = NumberRange("Magnitude", 1.0, 600.0, "N")  # the slider's range
# The push a robot gets by default: a share of its weight for a short time (150 N for every robot
# felled Solo12, 2.5 kg, which falls at 30 N).
PUSH_WEIGHT_SHARE = 0.15
PUSH_DEFAULT_MS = 100.0
GRAVITY = 9.81
PUSH_MS_RANGE = NumberRange("Duration", 20.0, 1000.0, "ms")


def push_force(direction: str, magnitude: float, yaw: float) -> list[float]:
    """The world force [N] of the push button `direction` (a key of PUSH_DIRECTIONS) of
    `magnitude` N on a robot heading `yaw` rad about z."""
    hx, hy = PUSH_DIRECTIONS[direction]
    c, s = np.cos(yaw), np.sin(yaw)
    return [magnitude * (c * hx - s * hy), magnitude * (s * hx + c * hy), 0.0]


def default_push_newtons(mass_kg: float) -> float:
    """The push magnitude offered for a robot of `mass_kg`: PUSH_WEIGHT_SHARE of its weight,
    whole newtons, inside the slider's range."""
    newtons = round(PUSH_WEIGHT_SHARE * mass_kg * GRAVITY)
    return float(min(max(newtons, PUSH_FORCE_RANGE.lo), PUSH_FORCE_RANGE.hi))


class PushControls:
    """The folder of one browser; `controls` are greyed while it may not act."""

    def __init__(self, app: PanelHost, client: viser.ClientHandle, order: float) -> None:
        self.app, self.client = app, client
        gui = client.gui
        with gui.add_folder("Push", order=order):
            self.force = gui.add_slider(
                "Magnitude [N]", PUSH_FORCE_RANGE.lo, PUSH_FORCE_RANGE.hi, 1.0, 10.0
            )
            self.ms = gui.add_slider(
                "Duration [ms]", PUSH_MS_RANGE.lo, PUSH_MS_RANGE.hi, 10.0, PUSH_DEFAULT_MS
            )
            pushes = gui.add_button_group("Push", tuple(PUSH_DIRECTIONS))
            self.note = gui.add_markdown("")
        self.controls: list = [self.force, self.ms, pushes]
        self.typed = TypedAt()
        for handle, limits in ((self.force, PUSH_FORCE_RANGE), (self.ms, PUSH_MS_RANGE)):
            handle.on_update(app.guard(lambda e, r=limits: self._slider_changed(e, r)))
        pushes.on_click(app.guard(lambda e: self.push(e.target.value)))

    def show_robot(self, mass_kg: float) -> None:
        """Another robot: its default push, no stale note."""
        self.note.content = ""
        self.force.value = default_push_newtons(mass_kg)
        self.ms.value = PUSH_DEFAULT_MS

    def _slider_changed(self, event: viser.GuiEvent, limits: NumberRange) -> None:
        """A typed slider number above the slider's maximum: the browser clamps it on leaving the
        box, so say so (a number below the minimum may be a prefix still being typed)."""
        if event.client_id is None:
            return
        self.typed.typed(limits.label)
        self.note.content = ""
        value = float(event.target.value)
        if value > limits.hi:
            self._note(
                "warning",
                f"{limits.label} {value:g} {limits.unit} is above the limit {limits.hi:g} "
                f"{limits.unit}: the box clamps it to {limits.hi:g} {limits.unit}",
            )

    def _note(self, level: str, text: str, category: str | None = None) -> None:
        note(self.app, self.client, self.note, level, text, category)

    def push(self, direction: str) -> None:
        """Push the base towards `direction` (a key of PUSH_DIRECTIONS) with the numbers
        shown."""
        busy = self.typed.busy(PUSH_FORCE_RANGE.label, PUSH_MS_RANGE.label)
        if busy:
            self._note("warning", busy_note(busy))
            show_value(self.force, float(self.force.value))
            show_value(self.ms, float(self.ms.value))
            return
        try:
            magnitude = PUSH_FORCE_RANGE.check(float(self.force.value))
            duration_ms = PUSH_MS_RANGE.check(float(self.ms.value))
        except NumberError as error:
            self._note("error", f"push not sent: {error}")
            return
        force = push_force(direction, magnitude, self.app.base_yaw())
        payload: dict[str, object] = {"body": self.app.base_body(), "force": force}
        payload["duration"] = duration_ms / 1000.0
        reply = self.app.send(self.client, "push", payload)
        # the boxes show exactly the numbers sent (a browser may hold another one, see above)
        show_value(self.force, magnitude)
        show_value(self.ms, duration_ms)
        if reply is not None and reply.get("ok"):
            self._note(
                "info", f"pushed {direction}: {magnitude:g} N for {duration_ms:g} ms", "push"
            )
