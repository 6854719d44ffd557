"""Draggable hand targets: one transform-controls gizmo per hand of the `hands` task (the robot's
`[hands]`), shown while the task is in the stack. Dragging or turning one sends a `hand` command
with its position and roll-pitch-yaw; each gizmo starts at the target `info` reports.
"""

from __future__ import annotations

import viser
import viser.transforms as tf

from lab.ui.balance_controls import CommandHost

TASK = "hands"
GIZMO_SCALE = 0.15  # m, the gizmo's arrows


class HandGizmos:
    """The gizmos of one browser; `show_info` makes them for the robot shown."""

    def __init__(self, app: CommandHost, client: viser.ClientHandle) -> None:
        self.app, self.client = app, client
        self.handles: dict[str, viser.TransformControlsHandle] = {}
        self._shown: tuple[str, tuple[str, ...]] | None = None  # the robot and its hands
        self._in_stack = False
        self._acts = False

    def show_info(self, info: dict) -> None:
        """New gizmos for another robot or another set of hands (an `info` from the middle of
        a switch may name the new robot before its hands), each at its hand's target (moved
        there when another client set it); shown while `hands` is in the stack. One call at a
        time (the app's `refresh_info`)."""
        hands = info.get("hands", [])
        shown = (info["robot"], tuple(hand["name"] for hand in hands))
        if shown != self._shown:
            self._shown = None  # until every gizmo is made: a frame that failed halfway retries
            for handle in self.handles.values():
                handle.remove()
            self.handles = {}
            for hand in hands:
                self.handles[hand["name"]] = self._gizmo(hand)
            self._shown = shown
        for hand in hands:
            handle = self.handles[hand["name"]]
            handle.position = tuple(hand["position"])  # no update callback: nothing is sent
            handle.wxyz = tf.SO3.from_rpy_radians(*hand["rpy"]).wxyz
        self._in_stack = any(TASK in level for level in info["stack"])
        self._show()

    def show_ownership(self, acts: bool) -> None:
        """Shown only to the browser that holds control (outside a replay)."""
        self._acts = acts
        self._show()

    def _show(self) -> None:
        for handle in self.handles.values():
            handle.visible = self._in_stack and self._acts

    def _gizmo(self, hand: dict) -> viser.TransformControlsHandle:
        name = hand["name"]
        handle = self.client.scene.add_transform_controls(
            f"/hands/{name}",
            scale=GIZMO_SCALE,
            position=tuple(hand["position"]),
            wxyz=tf.SO3.from_rpy_radians(*hand["rpy"]).wxyz,
            depth_test=False,
            visible=False,
        )
        handle.on_update(self.app.guard(lambda _: self._moved(name, handle)))
        return handle

    def _moved(self, name: str, handle: viser.TransformControlsHandle) -> None:
        rpy = tf.SO3(handle.wxyz).as_rpy_radians()
        payload = {
            "name": name,
            "position": [float(x) for x in handle.position],
            "rpy": [float(rpy.roll), float(rpy.pitch), float(rpy.yaw)],
        }
        self.app.send(self.client, "hand", payload)
