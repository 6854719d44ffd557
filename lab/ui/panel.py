"""The per-browser control panel: ownership banner, robot/scene/solver choice, gait choice and
velocity joystick, push buttons, reset/pause and the task stack editor with its presets.

Each browser gets its own panel (viser `client.gui`), so a read-only browser sees disabled
controls and a notice while the controlling one edits. Every edit goes through `PanelHost.send`,
which enforces ownership and reports rejected commands; the widgets then show what the server
acknowledged (the host calls `show_info` with the fresh `info` reply). The panel knows its host
only through `PanelHost` (the app implements it), never the app itself.

Over 400 lines: the widgets of one browser and their callbacks; the folders with their own job
live apart (`balance_controls`, `internal_force_controls`, `scene_setup`, `lab_picker`,
`recording`), as do the pure rules (`joystick`, `stack_edit`, `guard_rails`, `numbers`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol

import numpy as np
import viser

from lab.protocol import VelocityCommand
from lab.ui import stack_edit
from lab.ui.balance_controls import BalanceControls
from lab.ui.camera import followed, recentred
from lab.ui.gaits import gait_options
from lab.ui.guard_rails import stack_risks, standing_risks
from lab.ui.hand_gizmos import HandGizmos
from lab.ui.internal_force_controls import InternalForceControls
from lab.ui.joystick import JoystickLimits, from_offset, tap
from lab.ui.lab_picker import add_lab_picker
from lab.ui.numbers import NumberError, NumberRange, format_number
from lab.ui.realism_controls import RealismControls
from lab.ui.scene_setup import offer_scene_setup


class PanelHost(Protocol):
    """What a panel needs of the lab app: the acknowledged `info`, sending commands for its
    browser, reporting, and the robot's heading and pushable base."""

    info: dict | None

    def guard(self, callback: Callable) -> Callable:
        """`callback` with any exception reported in the page instead of raised."""

    def send(self, client: viser.ClientHandle, verb: str, payload: dict) -> dict | None:
        """Send a command for `client` (None when it does not hold control)."""

    def take_control(self, client_id: int) -> None: ...

    def switch_lab(self, client: viser.ClientHandle, lab_id: str) -> None: ...

    def set_velocity(self, client: viser.ClientHandle, cmd: VelocityCommand) -> None: ...

    def report(
        self,
        level: str,
        text: str,
        client: viser.ClientHandle | None = None,
        category: str | None = None,
    ) -> None:
        """A line in the event log (in `category`, lab/ui/event_log.py), popped up in
        `client`'s browser when given."""

    def notify_error(self, client: viser.ClientHandle, verb: str, error: str) -> None: ...

    def base_yaw(self) -> float: ...

    def base_body(self) -> str: ...


# Each push button by the way it pushes the robot: its force's unit vector in the heading frame.
# Herzog 2016 (Table 3) and its scenarios name a push by the side the pusher stands on instead:
# pushed "from the front" is the backward push here (docs/ui.md).
PUSH_DIRECTIONS = {
    "forward": (1.0, 0.0),
    "backward": (-1.0, 0.0),
    "left": (0.0, 1.0),
    "right": (0.0, -1.0),
}
HOTKEYS = {  # viser's camera uses W A S D Q E and the arrow keys
    "I": ("forward", "vx", 1),
    "K": ("back", "vx", -1),
    "J": ("left", "vy", 1),
    "L": ("right", "vy", -1),
    "U": ("turn left", "yaw_rate", 1),
    "O": ("turn right", "yaw_rate", -1),
}
STOP_HOTKEY = "X"
JOYSTICK_HEIGHT = 0.3  # m above the base: the pad floats over the robot
ROBOT_NOTES = {  # shown under the Robot dropdown while that robot runs
    "bolt": "Bolt stands on its two point feet by leaning its CoM to balance about the line "
    "between them (docs/controller.md): a push across that line fells it standing. Choose the "
    "biped_step gait to step: it walks where the velocity steers it and steps out of pushes.",
}
REPLAY_NOTE = (
    "**A recording** (`lab replay --serve`): play, pause, speed and seek it in *Replay* above. "
    "The robot, scene, controller, gait, velocity, push, balance and stack controls cannot act on "
    "a recording: they are greyed out (button rows hidden)."
)
PUSH_FORCE_RANGE = NumberRange("Magnitude", 1.0, 600.0, "N")  # the slider's range
# The push a robot gets by default: a share of its weight for a short time (150 N for every robot
# felled Solo12, 2.5 kg, which falls at 30 N).
PUSH_WEIGHT_SHARE = 0.15
PUSH_DEFAULT_MS = 100.0
GRAVITY = 9.81
PUSH_MS_RANGE = NumberRange("Duration", 20.0, 1000.0, "ms")
# Viser sends a typed number at most every 50 ms and a click in that window replaces the pending
# number (its throttle keeps only the newest message): a click this soon after a typed update may
# carry a number the box no longer shows, so it is refused with a message instead.
TYPING_SETTLE_S = 0.4


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


def _levels_markdown(levels: list[list[str]], selected: str, disabled: list[str]) -> str:
    rows = []
    for i, level in enumerate(levels):
        names = ", ".join(f"**[{t}]**" if t == selected else t for t in level)
        rows.append(f"{i}. {names}")
    if disabled:
        names = ", ".join(f"**[{t}]**" if t == selected else t for t in disabled)
        rows.append(f"\noff: {names}")
    return "Priority levels (0 = highest):\n\n" + "\n".join(rows)


class ControlPanel:
    def __init__(self, app: PanelHost, client: viser.ClientHandle) -> None:
        self.app = app
        self.client = client
        self.limits = JoystickLimits()
        self.velocity = VelocityCommand()
        self._yaw_from_slider = 0.0
        self._last_level: dict[str, int] = {}
        self._shown_robot: str | None = None  # the robot whose defaults the widgets hold
        gui = client.gui
        self._controls: list = []

        self.banner = gui.add_markdown("", order=1)
        self.replay_note = gui.add_markdown(REPLAY_NOTE, order=1.5, visible=False)
        self._owner: int | None = None  # the browser holding control, as last shown
        self._replay = False  # the lab is a recording (`lab replay --serve`): nothing acts
        self.take = gui.add_button("Take control", icon=viser.Icon.HAND_GRAB, order=2)
        self.take.on_click(app.guard(lambda _: app.take_control(client.client_id)))
        self.labs = add_lab_picker(app, client, order=2.5)
        self._controls.append(self.labs.dropdown)

        with gui.add_folder("Robot & controller", order=3):
            self.robot = gui.add_dropdown("Robot", ("…",))
            self.scene = gui.add_dropdown("Scene", ("…",))
            self.robot_note = gui.add_markdown("", visible=False)
            self.method = gui.add_dropdown("Hierarchy", ("…",))
            self.kernel = gui.add_dropdown(
                "Kernel", ("…",), hint="native (C++) or python; the status line says which ran"
            )
            self.solver = gui.add_dropdown("QP solver", ("…",))
            self.formulation = gui.add_dropdown(
                "Formulation", ("…",), hint="nullspace only: its optimization vector"
            )
            row = gui.add_button_group("Sim", ("Reset", "Pause", "Resume"))
            default_stack = gui.add_button(
                "Default stack",
                hint="reset the robot with its default task stack and gains (Reset keeps them)",
            )
            self.camera_follow = gui.add_checkbox(
                "Camera follows robot", True, hint="the view moves with the base as it walks"
            )
            recentre = gui.add_button("Re-centre camera")
        self._controls += [self.robot, self.scene, self.method, self.kernel, self.solver]
        self._controls += [self.formulation, row, default_stack]
        self._camera_base: np.ndarray | None = None  # the base's last position
        self.robot.on_update(
            app.guard(lambda e: self._switch(e, "robot", {"name": self.robot.value}))
        )
        self.scene.on_update(app.guard(self._switch_scene))
        self.method.on_update(app.guard(self._hierarchy))
        self.kernel.on_update(app.guard(self._hierarchy))
        default_stack.on_click(app.guard(lambda _: self._default_stack()))
        recentre.on_click(app.guard(lambda _: self.recentre()))
        self.solver.on_update(app.guard(self._hierarchy))
        self.formulation.on_update(app.guard(self._hierarchy))
        row.on_click(app.guard(lambda e: app.send(client, e.target.value.lower(), {})))

        with gui.add_folder("Gait & velocity", order=4):
            self.gait = gui.add_dropdown(
                "Gait", ("…",), hint="trot and crawl walk, steered by the velocity; stand balances"
            )
            gui.add_markdown(
                "Drag the pad over the robot (springs back on release). Keys: I/K forward/back, "
                "J/L left/right, U/O turn, X stop."
            )
            self.yaw = gui.add_slider(
                "Yaw rate", -self.limits.max_yaw_rate, self.limits.max_yaw_rate, 0.05, 0.0
            )
            self.command_text = gui.add_markdown("vx 0.00 · vy 0.00 · yaw 0.00")
            stop = gui.add_button("Stop", color="red", icon=viser.Icon.PLAYER_STOP)
        self._controls += [self.gait, self.yaw, stop]
        self.gait.on_update(app.guard(self._choose_gait))
        self.yaw.on_update(app.guard(self._yaw_changed))
        stop.on_click(app.guard(lambda _: self.stop()))
        for key, (label, axis, direction) in HOTKEYS.items():
            cmd = gui.add_command(f"Velocity: {label}", hotkey=key)
            cmd.on_trigger(app.guard(lambda _, a=axis, d=direction: self._tap(a, d)))
        stop_key = gui.add_command("Velocity: stop", hotkey=STOP_HOTKEY)
        stop_key.on_trigger(app.guard(lambda _: self.stop()))

        with gui.add_folder("Push", order=5):
            self.push_force = gui.add_slider(
                "Magnitude [N]", PUSH_FORCE_RANGE.lo, PUSH_FORCE_RANGE.hi, 1.0, 10.0
            )
            self.push_ms = gui.add_slider(
                "Duration [ms]", PUSH_MS_RANGE.lo, PUSH_MS_RANGE.hi, 10.0, PUSH_DEFAULT_MS
            )
            pushes = gui.add_button_group("Push", tuple(PUSH_DIRECTIONS))
            self.push_note = gui.add_markdown("")
        self._controls += [self.push_force, self.push_ms, pushes]
        self._typed_at: dict[str, float] = {}  # when each number field last changed
        for handle, limits in ((self.push_force, PUSH_FORCE_RANGE), (self.push_ms, PUSH_MS_RANGE)):
            handle.on_update(app.guard(lambda e, r=limits: self._slider_changed(e, r)))
        pushes.on_click(app.guard(lambda e: self.push(e.target.value)))

        self.balance = BalanceControls(app, gui, order=5.5)
        self._controls += self.balance.controls
        self.internal_force = InternalForceControls(app, gui, order=5.6)
        self._controls += self.internal_force.controls
        self.realism = RealismControls(app, gui, order=5.7)
        self._controls += self.realism.controls
        with gui.add_folder("Task stack", order=6):
            self.stack_view = gui.add_markdown("")
            self.stack_risk = gui.add_markdown("", visible=False)
            self.task = gui.add_dropdown("Task", ("…",))
            moves = gui.add_button_group("Move", ("▲ level", "▼ level", "new ▲", "new ▼"))
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
        self._controls += [self.task, moves, self.enabled, self.kp, self.kd, self.weight, apply]
        self._controls += [self.preset, load]
        self.task.on_update(app.guard(lambda _: self._show_task()))
        moves.on_click(app.guard(lambda e: self._move(e.target.value)))
        self.enabled.on_update(app.guard(self._toggle_enabled))
        apply.on_click(app.guard(lambda _: self._apply_gains()))
        for handle in (self.kp, self.kd, self.weight):
            handle.on_update(app.guard(self._typed))
        load.on_click(app.guard(lambda _: app.send(client, "stack", {"preset": self.preset.value})))

        self._follow = client.scene.add_frame("/joystick", show_axes=False)
        self.pad = client.scene.add_transform_controls(
            "/joystick/pad",
            scale=0.25,
            active_axes=(True, True, False),
            disable_rotations=True,
            translation_limits=((-0.4, 0.4), (-0.4, 0.4), (0.0, 0.0)),
            depth_test=False,
        )
        self.pad.on_update(app.guard(self._pad_moved))
        self.hands = HandGizmos(app, client)  # the hands task's targets, dragged in the scene

    # ---- ownership -------------------------------------------------------------------------
    def show_ownership(self, owner: int | None) -> None:
        """Enable the controls for the browser holding control, unless the lab is a recording
        (then every control but the lab picker is greyed out, button rows hidden: viser cannot
        disable those, and the note above says why)."""
        self._owner = owner
        mine = owner == self.client.client_id
        if mine:
            self.banner.content = "**You hold control** of the robot."
        elif owner is None:
            self.banner.content = "Nobody holds control: press *Take control*."
        else:
            self.banner.content = (
                f"**Read-only**: browser #{owner} holds control. Press *Take control* to drive."
            )
        self.take.visible = not mine
        acts = mine and not self._replay
        for handle in self._controls:
            if isinstance(handle, viser.GuiButtonGroupHandle):
                handle.visible = acts  # viser cannot disable a button group: hide it instead
            else:
                handle.disabled = not (mine if handle is self.labs.dropdown else acts)
        self.pad.visible = acts
        self.hands.show_ownership(acts)
        self.replay_note.visible = self._replay

    # ---- info / telemetry -----------------------------------------------------------------------
    def show_info(self, info: dict) -> None:
        """Set every widget to the server's acknowledged state without re-sending it (an
        assignment here calls the widgets' callbacks with no client: they send nothing)."""
        for dropdown, options, value in (
            (self.robot, info["robots"], info["robot"]),
            (self.scene, info["scenes"], info["scene"]),
            (self.method, info["methods"], info["hierarchy"]["method"]),
            (self.kernel, info["kernels"], info["kernel"]),
            (self.solver, info["solvers"], info["hierarchy"]["solver"]),
            (self.formulation, info["formulations"], info["hierarchy"]["formulation"]),
            (self.gait, gait_options(info["gaits"], info["gait"]), info["gait"]),
        ):
            dropdown.options = tuple(options)
            dropdown.value = value
        names = [t["name"] for t in info["tasks"]]
        if names:
            current = self.task.value if self.task.value in names else names[0]
            self.task.options = tuple(names)
            self.task.value = current
        if info["stack_presets"]:
            self.preset.options = tuple(info["stack_presets"])
        if ("replay" in info) != self._replay:  # a recording, or a live lab again
            self._replay = "replay" in info
            self.show_ownership(self._owner)
        if info["robot"] != self._shown_robot:  # another robot: its defaults, no stale notes
            self._shown_robot = info["robot"]
            self.push_note.content = self.gains_note.content = ""
            self.push_force.value = default_push_newtons(info.get("mass", 0.0))
            self.push_ms.value = PUSH_DEFAULT_MS
        note = ROBOT_NOTES.get(info["robot"], "")
        self.robot_note.content, self.robot_note.visible = note, bool(note)
        self.balance.show_info(info)
        self.internal_force.show_info(info)
        self.hands.show_info(info)
        self.realism.show_info(info)
        self._show_task()

    def _show_task(self) -> None:
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
        self.stack_view.content = _levels_markdown(levels, name, disabled)

    def show_command(self, command: dict) -> None:
        self.command_text.content = (
            f"vx {command['vx']:+.2f} m/s · vy {command['vy']:+.2f} m/s · "
            f"yaw {command['yaw_rate']:+.2f} rad/s"
        )

    def follow_robot(self, position: np.ndarray, yaw: float) -> None:
        """Keep the joystick pad over the base and, when following, the camera on it."""
        self._follow.position = position + np.array([0.0, 0.0, JOYSTICK_HEIGHT])
        self._follow.wxyz = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
        self._camera_base = position
        if not self.camera_follow.value:
            return
        camera = self.client.camera
        moved = followed(camera.position, camera.look_at, position)
        if moved is not None:
            with self.client.atomic():
                camera.position, camera.look_at = moved

    def recentre(self) -> None:
        """The camera back to the default view of the base."""
        if self._camera_base is not None:
            position, look_at = recentred(self._camera_base)
            with self.client.atomic():
                self.client.camera.position, self.client.camera.look_at = position, look_at

    # ---- commands --------------------------------------------------------------------------
    # Viser calls a widget's callbacks from a thread pool for a browser's change, and at once
    # with no client for an assignment in this process (`show_info`): only the first is the user.
    def _switch(self, event: viser.GuiEvent, verb: str, payload: dict) -> None:
        if event.client_id is not None:
            self.app.send(self.client, verb, payload)

    def _switch_scene(self, event: viser.GuiEvent) -> None:
        """Switch the scene, then offer the set-up it was made for (`scene_setup.py`)."""
        if event.client_id is None:
            return
        scene = self.scene.value
        reply = self.app.send(self.client, "scene", {"name": scene})
        info = self.app.info
        if reply is not None and reply.get("ok") and info is not None:
            offer_scene_setup(self.app, self.client, scene, info["robot"], info.get("mass", 0.0))

    def _hierarchy(self, event: viser.GuiEvent) -> None:
        if event.client_id is not None:
            payload = {
                "method": self.method.value,
                "solver": self.solver.value,
                "formulation": self.formulation.value,
                "kernel": self.kernel.value,
            }
            self.app.send(self.client, "hierarchy", payload)

    def _default_stack(self) -> None:
        """A robot switch to the same robot: the server rebuilds it with its default stack."""
        info = self.app.info
        if info is not None:
            self.app.send(self.client, "robot", {"name": info["robot"]})
            self.app.report(
                "info", f"{info['robot']} reset with its default stack and gains", category="reset"
            )

    def _choose_gait(self, event: viser.GuiEvent) -> None:
        if event.client_id is None:
            return
        name = self.gait.value
        reply = self.app.send(self.client, "gait", {"name": name})
        if reply and reply.get("ok") and "preset" in reply:
            self.client.add_notification(
                f"Stack preset {reply['preset']}",
                f"{name} needs the swing-foot task: the walking stack is installed",
                auto_close_seconds=6.0,
                with_close_button=True,
            )

    def _set_velocity(self, cmd: VelocityCommand) -> None:
        self.velocity = cmd
        self.app.set_velocity(self.client, cmd)

    def _pad_moved(self, event: viser.TransformControlsEvent) -> None:
        if event.phase == "end":
            self.pad.position = (0.0, 0.0, 0.0)  # spring back
            dx = dy = 0.0
        else:
            dx, dy = float(self.pad.position[0]), float(self.pad.position[1])
        self._set_velocity(from_offset(dx, dy, self._yaw_from_slider, self.limits))

    def _yaw_changed(self, event: viser.GuiEvent) -> None:
        if event.client_id is None:
            return
        self._yaw_from_slider = float(self.yaw.value)
        v = self.velocity
        self._set_velocity(VelocityCommand(v.vx, v.vy, self._yaw_from_slider))

    def _tap(self, axis: str, direction: int) -> None:
        cmd = tap(self.velocity, axis, direction, self.limits)
        self._yaw_from_slider = cmd.yaw_rate
        self.yaw.value = cmd.yaw_rate
        self._set_velocity(cmd)

    def stop(self) -> None:
        self.zero_velocity()
        self._set_velocity(VelocityCommand())

    def zero_velocity(self) -> None:
        """Show a zero velocity command (without sending one): the next tap starts from 0."""
        self._yaw_from_slider = 0.0
        self.yaw.value = 0.0
        self.pad.position = (0.0, 0.0, 0.0)
        self.velocity = VelocityCommand()

    def _slider_changed(self, event: viser.GuiEvent, limits: NumberRange) -> None:
        """A typed slider number above the slider's maximum: the browser clamps it on leaving the
        box, so say so (a number below the minimum may be a prefix still being typed)."""
        if event.client_id is None:
            return
        self._typed_at[limits.label] = time.monotonic()
        self.push_note.content = ""
        value = float(event.target.value)
        if value > limits.hi:
            self.note(
                self.push_note,
                "warning",
                f"{limits.label} {value:g} {limits.unit} is above the limit {limits.hi:g} "
                f"{limits.unit}: the box clamps it to {limits.hi:g} {limits.unit}",
            )

    def _typed(self, event: viser.GuiEvent) -> None:
        if event.client_id is not None:  # typed in the browser, not set from `info`
            self._typed_at[event.target.label] = time.monotonic()
            self.gains_note.content = ""

    def note(
        self, where: viser.GuiMarkdownHandle, level: str, text: str, category: str | None = None
    ) -> None:
        """A message under the widgets it is about, in the event log (in `category`), and
        popped up."""
        where.content = f"{'⚠' if level != 'info' else '✔'} {text}"
        self.app.report(level, text, self.client if level != "info" else None, category)

    def _settled(self, *labels: str) -> bool:
        """False (and a message) when a number field changed too recently to be trusted."""
        now = time.monotonic()
        busy = [k for k in labels if now - self._typed_at.get(k, -1e9) < TYPING_SETTLE_S]
        if not busy:
            return True
        where = self.push_note if busy[0] in ("Magnitude", "Duration") else self.gains_note
        self.note(
            where,
            "warning",
            f"{', '.join(busy)} changed less than {TYPING_SETTLE_S:g} s ago: the typed number may "
            "not have reached the lab yet. Nothing sent: check the box and press again",
        )
        return False

    def push(self, direction: str) -> None:
        if not self._settled("Magnitude", "Duration"):
            self._show_value(self.push_force, float(self.push_force.value))
            self._show_value(self.push_ms, float(self.push_ms.value))
            return
        try:
            magnitude = PUSH_FORCE_RANGE.check(float(self.push_force.value))
            duration_ms = PUSH_MS_RANGE.check(float(self.push_ms.value))
        except NumberError as error:
            self.note(self.push_note, "error", f"push not sent: {error}")
            return
        force = push_force(direction, magnitude, self.app.base_yaw())
        payload = {"body": self.app.base_body(), "force": force}
        payload["duration"] = duration_ms / 1000.0
        reply = self.app.send(self.client, "push", payload)
        # the boxes show exactly the numbers sent (a browser may hold another one, see above)
        self._show_value(self.push_force, magnitude)
        self._show_value(self.push_ms, duration_ms)
        if reply is not None and reply.get("ok"):
            self.note(
                self.push_note,
                "info",
                f"pushed {direction}: {magnitude:g} N for {duration_ms:g} ms",
                category="push",
            )

    def _show_value(self, handle: viser.GuiInputHandle, value: float | str) -> None:
        """Make the browser show `value` in `handle` even if this process already holds it."""
        # viser skips an assignment of the value it holds: assign another one first
        handle.value = value + " " if isinstance(value, str) else value + 1.0
        handle.value = value

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
                self._show_task()  # the editor shows the stack the server still holds

        apply.on_click(self.app.guard(lambda _: decide(True)))
        cancel.on_click(self.app.guard(lambda _: decide(False)))

    def _move(self, which: str) -> None:
        info = self.app.info
        task = self.task.value
        if info is None:
            return
        levels = [list(level) for level in info["stack"]]
        ops = {
            "▲ level": stack_edit.move_to_level_above,
            "▼ level": stack_edit.move_to_level_below,
            "new ▲": lambda lv, t: stack_edit.move_to_new_level(lv, t, above=True),
            "new ▼": lambda lv, t: stack_edit.move_to_new_level(lv, t, above=False),
        }
        try:
            new = ops[which](levels, task)
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
        task = (
            next((t for t in info["tasks"] if t["name"] == self.task.value), None) if info else None
        )
        if task is None:
            return
        if not self._settled("kp", "kd", "weight"):
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
            self.note(self.gains_note, "error", f"gains of {task['name']} not applied: {error}")
            return
        reply = self.app.send(self.client, "gains", payload)
        for key, value in payload.items():
            if key != "task":  # the boxes show exactly the numbers sent
                self._show_value(fields[key][0], format_number(value))
        if reply is not None and reply.get("ok"):
            sent = ", ".join(f"{k} {format_number(v)}" for k, v in payload.items() if k != "task")
            self.note(self.gains_note, "info", f"{task['name']}: {sent} applied")

    def remove(self) -> None:
        self.pad.remove()
        self._follow.remove()
