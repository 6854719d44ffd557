"""The per-browser control panel: the control banner, the lab picker, the robot / scene /
controller choice with the sim's buttons and the camera, and the folders of their own modules
(gait and velocity, push, balance, internal force, realism, task stack, the hand gizmos).

Each browser gets its own panel (viser `client.gui`), so a read-only browser sees disabled
controls and a notice while the controlling one edits. Every edit goes through `PanelHost.send`,
which enforces control (this browser's, and the page's hold on the lab's control lock) and
reports rejected commands; the widgets then show what the server acknowledged (the host calls
`show_info` with the fresh `info` reply). The panel knows its host only through `PanelHost`
(`panel_host.py`; the app implements it), never the app itself.
"""

from __future__ import annotations

import numpy as np
import viser

from lab.ui.balance_controls import BalanceControls
from lab.ui.camera import followed, recentred
from lab.ui.hand_gizmos import HandGizmos
from lab.ui.internal_force_controls import InternalForceControls
from lab.ui.lab_picker import add_lab_picker
from lab.ui.panel_host import PanelHost
from lab.ui.push_controls import PushControls
from lab.ui.realism_controls import RealismControls
from lab.ui.scene_setup import switch_scene
from lab.ui.stack_editor import StackEditor
from lab.ui.velocity_controls import VelocityControls

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


def banner(me: int, owner: int | None, lock_holder: str | None) -> str:
    """The control banner of browser `me`: which browser of the page holds control (`owner`)
    and, when another client of the lab holds its control lock, which one."""
    locked = (
        ""
        if lock_holder is None
        else f"Client `{lock_holder}` holds the lab's control lock (a terminal teleop or a "
        "script): the page reads only until it is released."
    )
    if owner == me:
        if locked:
            return f"**Read-only**: {locked} Press *Take control* to ask for it."
        return "**You hold control** of the robot."
    if owner is None:
        return f"Nobody holds control: press *Take control*. {locked}".strip()
    return (
        f"**Read-only**: browser #{owner} holds control. Press *Take control* to drive. {locked}"
    ).strip()


class ControlPanel:
    """The panel of one browser (see the module docstring)."""

    def __init__(self, app: PanelHost, client: viser.ClientHandle) -> None:
        self.app = app
        self.client = client
        self._shown_robot: str | None = None  # the robot whose defaults the widgets hold
        gui = client.gui
        self._controls: list = []

        self.banner = gui.add_markdown("", order=1)
        self.replay_note = gui.add_markdown(REPLAY_NOTE, order=1.5, visible=False)
        self._owner: int | None = None  # the browser holding control, as last shown
        self._lock_holder: str | None = None  # another client holding the lab's lock, as shown
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

        self.velocity_controls = VelocityControls(app, client, order=4)
        self.push = PushControls(app, client, order=5)
        self.balance = BalanceControls(app, gui, order=5.5)
        self.internal_force = InternalForceControls(app, gui, order=5.6)
        self.realism = RealismControls(app, gui, order=5.7)
        self.stack = StackEditor(app, client, order=6)
        for part in (self.velocity_controls, self.push, self.balance, self.internal_force):
            self._controls += part.controls
        self._controls += self.realism.controls + self.stack.controls
        self.hands = HandGizmos(app, client)  # the hands task's targets, dragged in the scene

    # ---- ownership -------------------------------------------------------------------------
    def show_ownership(self, owner: int | None, lock_holder: str | None = None) -> None:
        """Enable the controls for the browser holding control while no other client holds
        the lab's control lock (`lock_holder`), unless the lab is a recording (then every
        control but the lab picker is greyed out, button rows hidden: viser cannot disable
        those, and the note above says why)."""
        self._owner, self._lock_holder = owner, lock_holder
        mine = owner == self.client.client_id
        self.banner.content = banner(self.client.client_id, owner, lock_holder)
        self.take.visible = not mine or lock_holder is not None
        acts = mine and lock_holder is None and not self._replay
        for handle in self._controls:
            if isinstance(handle, viser.GuiButtonGroupHandle):
                handle.visible = acts  # viser cannot disable a button group: hide it instead
            else:
                handle.disabled = not (mine if handle is self.labs.dropdown else acts)
        self.velocity_controls.pad.visible = acts
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
        ):
            dropdown.options = tuple(options)
            dropdown.value = value
        self.velocity_controls.show_info(info)
        if ("replay" in info) != self._replay:  # a recording, or a live lab again
            self._replay = "replay" in info
            self.show_ownership(self._owner, self._lock_holder)
        if info["robot"] != self._shown_robot:  # another robot: its defaults, no stale notes
            self._shown_robot = info["robot"]
            self.push.show_robot(info.get("mass", 0.0))
            self.stack.show_robot()
        note = ROBOT_NOTES.get(info["robot"], "")
        self.robot_note.content, self.robot_note.visible = note, bool(note)
        self.balance.show_info(info)
        self.internal_force.show_info(info)
        self.hands.show_info(info)
        self.realism.show_info(info)
        self.stack.show_info(info)

    def follow_robot(self, position: np.ndarray, yaw: float) -> None:
        """Keep the joystick pad over the base and, when following, the camera on it."""
        self.velocity_controls.follow(position, yaw)
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
        """Switch the scene, asking first whether with the set-up it was made for
        (`scene_setup.py`)."""
        if event.client_id is None:
            return
        info = self.app.info or {"robot": None, "mass": 0.0}  # None: no lab answered yet
        switch_scene(self.app, self.client, self.scene.value, info["robot"], info["mass"])

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

    def remove(self) -> None:
        self.velocity_controls.remove()
