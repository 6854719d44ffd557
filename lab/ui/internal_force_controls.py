"""The panel's "Internal force (Kim 2016)" folder: the reference F_int,ref of the tension
between two point feet and its feedback gain K_F (eq. 12: the `internal_force` task's kp), so
that Kim's Fig. 6 (Bolt on the split wedges) can be tried live. Shown while the
`internal_force` task is in the stack; the internal-force chart beside it shows the reference,
the sensed value and the command.
"""

from __future__ import annotations

import viser

from lab.ui.balance_controls import CommandHost
from lab.ui.numbers import NumberError, NumberRange, format_number

TASK = "internal_force"
REFERENCE_RANGE = NumberRange("Reference", -500.0, 500.0, "N")  # tension < 0 < pushing apart


class InternalForceControls:
    """Reference and gain boxes and *Apply*: an `internal_force` command for the reference and
    a `gains` command for K_F; the boxes show the acknowledged values from `info` and replies."""

    def __init__(self, app: CommandHost, gui: viser.GuiApi, order: float) -> None:
        self.folder = gui.add_folder("Internal force (Kim 2016)", order=order, visible=False)
        with self.folder:
            hint = "a number as typed; out of range is refused, naming the limit"
            self.reference = gui.add_text("Reference [N]", "0", hint=hint + " (> 0: apart)")
            self.gain = gui.add_text("Gain K_F", "0", hint=hint + " (the task's kp, eq. 12)")
            apply = gui.add_button("Apply internal force")
            self.note = gui.add_markdown("")
        self.app = app
        self._gain_max = 1e5
        self.controls: list = [self.reference, self.gain, apply]
        apply.on_click(app.guard(self._apply))

    def show_info(self, info: dict) -> None:
        """Shown while the task is in the stack, with its acknowledged gain."""
        self.folder.visible = any(TASK in level for level in info["stack"])
        self._gain_max = info.get("limits", {}).get("gain", self._gain_max)
        task = next((t for t in info["tasks"] if t["name"] == TASK), None)
        if task is not None and task["kp"] is not None:
            self.gain.value = format_number(task["kp"])

    def _apply(self, event: viser.GuiEvent) -> None:
        if event.client is None:
            return
        try:
            reference = REFERENCE_RANGE.parse(self.reference.value)
            gain = NumberRange("K_F", 0.0, self._gain_max).parse(self.gain.value)
        except NumberError as error:
            self.note.content = f"⚠ not applied: {error}"
            return
        reply = self.app.send(event.client, "internal_force", {"reference": reference})
        if reply is None or not reply.get("ok"):
            self.note.content = "⚠ the reference was refused: see the event log"
            return
        reply = self.app.send(event.client, "gains", {"task": TASK, "kp": gain})
        if reply is not None and reply.get("ok"):
            self.note.content = (
                f"✔ reference {format_number(reference)} N, K_F {format_number(reply['kp'])}"
            )
