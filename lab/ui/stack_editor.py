"""The panel's "Task stack" folder: the priority levels the lab runs, a task's level moved or
the task disabled (a stack that will drop the robot is explained first, applied only on *Apply
anyway*), its gains typed and applied (refused naming the limit), and a stack preset loaded.
The edits themselves are `stack_edit.py`'s, the warnings `guard_rails.py`'s.
"""

from __future__ import annotations

import viser

from lab.ui import stack_edit
from lab.ui.guard_rails import stack_risks, standing_risks
from lab.ui.number_fields import TypedAt, busy_note, note, show_value
from lab.ui.numbers import NumberError, NumberRange, format_number
from lab.ui.panel_host import PanelHost

MOVES = {
    "▲ level": stack_edit.move_to_level_above,
    "▼ level": stack_edit.move_to_level_below,
    "new ▲": lambda levels, task: stack_edit.move_to_new_level(levels, task, above=True),
    "new ▼": lambda levels, task: stack_edit.move_to_new_level(levels, task, above=False),
}


def levels_markdown(levels: list[list[str]], selected: str, disabled: list[str]) -> str:
    """The stack as numbered levels, `selected` in brackets, the disabled tasks below."""
    rows = []
    for i, level in enumerate(levels):
        names = ", ".join(f"**[{t}]**" if t == selected else t for t in level)
        rows.append(f"{i}. {names}")
    if disabled:
        names = ", ".join(f"**[{t}]**" if t == selected else t for t in disabled)
        rows.append(f"\noff: {names}")
    return "Priority levels (0 = highest):\n\n" + "\n".join(rows)


class StackEditor:
    """The folder of one browser; `controls` are greyed while it may not act."""

    def __init__(self, app: PanelHost, client: viser.ClientHandle, order: float) -> None:
        self.app, self.client = app, client
        self._last_level: dict[str, int] = {}  # where a disabled task was, to enable it there
        gui = client.gui
        with gui.add_folder("Task stack", order=order):
            self.stack_view = gui.add_markdown("")
            self.stack_risk = gui.add_markdown("", visible=False)
            self.task = gui.add_dropdown("Task", ("…",))
            moves = gui.add_button_group("Move", tuple(MOVES))
            self.enabled = gui.add_checkbox("Enabled", True)
            # Text boxes: the number is read as typed ("1e9", "-5") and checked against the
            # limits of `info`, never clamped or stripped by the browser's number box.
            hint = "a number, e.g. 100 or 1e-3; out of range is refused, naming the limit"
            self.kp = gui.add_text("kp", "0", hint=hint)
            self.kd = gui.add_text("kd", "0", hint=hint)
            self.weight = gui.add_text("weight", "1", hint=hint)
            apply = gui.add_button("Apply gains")
            self.gains_note = gui.add_markdown("")
            self.preset = gui.add_dropdown(
                "Preset", ("…",), hint="a stack of stacks/: its levels, gains and hierarchy"
            )
            load = gui.add_button("Load preset")
        self.controls: list = [self.task, moves, self.enabled, self.kp, self.kd, self.weight]
        self.controls += [apply, self.preset, load]
        self.typed = TypedAt()
        self.task.on_update(app.guard(lambda _: self.show_task()))
        moves.on_click(app.guard(lambda e: self._move(e.target.value)))
        self.enabled.on_update(app.guard(self._toggle_enabled))
        apply.on_click(app.guard(lambda _: self._apply_gains()))
        for handle in (self.kp, self.kd, self.weight):
            handle.on_update(app.guard(self._typed))
        load.on_click(app.guard(lambda _: app.send(client, "stack", {"preset": self.preset.value})))

    def show_info(self, info: dict) -> None:
        """The tasks and presets the lab offers; then the stack (`show_task`)."""
        names = [t["name"] for t in info["tasks"]]
        if names:
            current = self.task.value if self.task.value in names else names[0]
            self.task.options = tuple(names)
            self.task.value = current
        if info["stack_presets"]:
            self.preset.options = tuple(info["stack_presets"])
        self.show_task()

    def show_robot(self) -> None:
        """Another robot: no stale note."""
        self.gains_note.content = ""

    def show_task(self) -> None:
        """The stack the lab holds, the chosen task marked, its fields filled."""
        info = self.app.info
        if info is None:
            return
        levels = [list(level) for level in info["stack"]]
        tasks = {t["name"]: t for t in info["tasks"]}
        in_stack = {t for level in levels for t in level}
        disabled = [name for name in tasks if name not in in_stack]
        name = self.task.value
        task = tasks.get(name)
        if task is not None:
            self.enabled.value = name in in_stack
            for handle, key in ((self.kp, "kp"), (self.kd, "kd"), (self.weight, "weight")):
                has = task[key] is not None
                handle.visible = has
                if has:
                    handle.value = format_number(task[key])
        risks = standing_risks(levels, list(tasks), info["gait"])
        self.stack_risk.content = "\n\n".join(f"⚠ {risk}" for risk in risks)
        self.stack_risk.visible = bool(risks)
        # last: once the editor marks the task, the fields above show it (the browser tests wait
        # for the mark before they type or click)
        self.stack_view.content = levels_markdown(levels, name, disabled)

    def _typed(self, event: viser.GuiEvent) -> None:
        if event.client_id is not None:  # typed in the browser, not set from `info`
            self.typed.typed(event.target.label)
            self.gains_note.content = ""

    def _send_stack(self, levels: list[list[str]]) -> None:
        """Send `levels`; a stack that will drop the robot is first explained in a dialog that
        applies it only on *Apply anyway* (a lab allows it)."""
        risks = stack_risks(levels)
        if not risks:
            self.app.send(self.client, "stack", {"levels": levels})
            return
        gui = self.client.gui
        with gui.add_modal("This stack will drop the robot") as modal:
            gui.add_markdown("\n\n".join(f"⚠ {risk}" for risk in risks))
            apply = gui.add_button("Apply anyway", color="red")
            cancel = gui.add_button("Cancel")

        def decide(applied: bool) -> None:
            modal.close()
            if applied:
                self.app.report("warning", f"stack applied anyway: {'; '.join(risks)}")
                self.app.send(self.client, "stack", {"levels": levels})
            else:
                self.show_task()  # the editor shows the stack the server still holds

        apply.on_click(self.app.guard(lambda _: decide(True)))
        cancel.on_click(self.app.guard(lambda _: decide(False)))

    def _move(self, which: str) -> None:
        info = self.app.info
        if info is None:
            return
        levels = [list(level) for level in info["stack"]]
        try:
            new = MOVES[which](levels, self.task.value)
        except ValueError as exc:
            self.app.notify_error(self.client, "stack", str(exc))
            return
        self._send_stack(new)

    def _toggle_enabled(self, event: viser.GuiEvent) -> None:
        info = self.app.info
        if event.client_id is None or info is None:
            return
        levels = [list(level) for level in info["stack"]]
        task = self.task.value
        try:
            if self.enabled.value:
                new = stack_edit.enable_task(levels, task, self._last_level.get(task, len(levels)))
            else:
                self._last_level[task] = stack_edit.find_task(levels, task)[0]
                new = stack_edit.disable_task(levels, task)
        except ValueError as exc:
            self.app.notify_error(self.client, "stack", str(exc))
            return
        self._send_stack(new)

    def _apply_gains(self) -> None:
        info = self.app.info
        if info is None:
            return
        task = next((t for t in info["tasks"] if t["name"] == self.task.value), None)
        if task is None:
            return
        busy = self.typed.busy("kp", "kd", "weight")
        if busy:
            note(self.app, self.client, self.gains_note, "warning", busy_note(busy))
            return
        limits = info.get("limits", {})
        gain_max, weight_max = limits.get("gain", 1e5), limits.get("weight", 1e8)
        fields = {
            "kp": (self.kp, NumberRange("kp", 0.0, gain_max)),
            "kd": (self.kd, NumberRange("kd", 0.0, gain_max)),
            "weight": (self.weight, NumberRange("weight", 0.0, weight_max, lo_open=True)),
        }
        payload: dict = {"task": task["name"]}
        try:
            for key, (handle, limits) in fields.items():
                if task[key] is not None:
                    payload[key] = limits.parse(handle.value)
        except NumberError as error:
            text = f"gains of {task['name']} not applied: {error}"
            note(self.app, self.client, self.gains_note, "error", text)
            return
        reply = self.app.send(self.client, "gains", payload)
        for key, value in payload.items():
            if key != "task":  # the boxes show exactly the numbers sent
                show_value(fields[key][0], format_number(value))
        if reply is not None and reply.get("ok"):
            sent = ", ".join(f"{k} {format_number(v)}" for k, v in payload.items() if k != "task")
            note(self.app, self.client, self.gains_note, "info", f"{task['name']}: {sent} applied")
