"""The panel's "Gait & velocity" folder and the joystick pad over the robot: the gait choice,
the velocity command from the pad, the yaw slider and the hotkeys, and the command in effect.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import viser

from lab.protocol import VelocityCommand
from lab.ui.gaits import gait_options
from lab.ui.joystick import JoystickLimits, from_offset, tap
from lab.ui.panel_host import PanelHost

Key = Literal["I", "K", "J", "L", "U", "O", "X"]  # the page's hotkeys (viser's names)
HOTKEYS: dict[Key, tuple[str, str, int]] = {  # viser's camera uses W A S D Q E and the arrows
    "I": ("forward", "vx", 1),
    "K": ("back", "vx", -1),
    "J": ("left", "vy", 1),
    "L": ("right", "vy", -1),
    "U": ("turn left", "yaw_rate", 1),
    "O": ("turn right", "yaw_rate", -1),
}
STOP_HOTKEY: Key = "X"
JOYSTICK_HEIGHT = 0.3  # m above the base: the pad floats over the robot


class VelocityControls:
    """The folder and pad of one browser; `controls` are greyed (the pad hidden) while it may
    not act."""

    def __init__(self, app: PanelHost, client: viser.ClientHandle, order: float) -> None:
        self.app, self.client = app, client
        self.limits = JoystickLimits()
        self.velocity = VelocityCommand()  # the command this browser sent last
        self._yaw_from_slider = 0.0
        gui = client.gui
        with gui.add_folder("Gait & velocity", order=order):
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
        self.controls: list = [self.gait, self.yaw, stop]
        self.gait.on_update(app.guard(self._choose_gait))
        self.yaw.on_update(app.guard(self._yaw_changed))
        stop.on_click(app.guard(lambda _: self.stop()))
        for key, (label, axis, direction) in HOTKEYS.items():
            cmd = gui.add_command(f"Velocity: {label}", hotkey=key)
            cmd.on_trigger(app.guard(lambda _, a=axis, d=direction: self._tap(a, d)))
        stop_key = gui.add_command("Velocity: stop", hotkey=STOP_HOTKEY)
        stop_key.on_trigger(app.guard(lambda _: self.stop()))

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

    def show_info(self, info: dict) -> None:
        """The gaits the robot offers and the one running (without sending it back)."""
        self.gait.options = tuple(gait_options(info["gaits"], info["gait"]))
        self.gait.value = info["gait"]

    def show_command(self, command: dict) -> None:
        """The velocity command in effect (telemetry's `command`)."""
        self.command_text.content = (
            f"vx {command['vx']:+.2f} m/s · vy {command['vy']:+.2f} m/s · "
            f"yaw {command['yaw_rate']:+.2f} rad/s"
        )

    def follow(self, position: np.ndarray, yaw: float) -> None:
        """Keep the pad over the base."""
        self._follow.position = position + np.array([0.0, 0.0, JOYSTICK_HEIGHT])
        self._follow.wxyz = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])

    # Viser calls a widget's callbacks from a thread pool for a browser's change, and at once
    # with no client for an assignment in this process (`show_info`): only the first is the user.
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
        """Zero the velocity command, shown and sent."""
        self.zero()
        self._set_velocity(VelocityCommand())

    def zero(self) -> None:
        """Show a zero velocity command (without sending one): the next tap starts from 0."""
        self._yaw_from_slider = 0.0
        self.yaw.value = 0.0
        self.pad.position = (0.0, 0.0, 0.0)
        self.velocity = VelocityCommand()

    def remove(self) -> None:
        self.pad.remove()
        self._follow.remove()
