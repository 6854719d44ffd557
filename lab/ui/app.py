"""The browser lab: a viser server that draws what the sim process publishes and sends commands.

It talks to the sim process only through Zenoh (`lab.ui.link`, `lab.protocol`); it reads robot
descriptions (TOML, URDF visuals) and scene geometry, all plain data, and imports neither the
controller, pinocchio nor MuJoCo (tests/ui/test_ui_logic.py checks).

This module is what the app does for its browsers: the shared widgets, the browsers coming and
going, which one holds control (`ownership.py`) and the lab's control lock the page takes for
them (`lab_lock.py`), and the command path (each browser's panel sends through `send`). What
it does for each message and frame is the render loop's (`render_loop.py`); the 3-D scene is
`scene_view.py`'s, each browser's panel `panel.py`'s.
"""

import functools
import math
import threading
import time
import traceback
from collections.abc import Callable
from concurrent import futures
from concurrent.futures import Future, ThreadPoolExecutor
from typing import ParamSpec

import numpy as np
import viser
import zenoh

from lab.protocol import READ_ONLY_VERBS, CommandStruct, VelocityCommand
from lab.ui.drag_push import DragPush
from lab.ui.event_log import ALL, CATEGORIES, EventLog
from lab.ui.hotkeys import install_hotkey_script
from lab.ui.internal_force_plot import add_internal_force_plot
from lab.ui.lab_lock import LabLock
from lab.ui.link import Link
from lab.ui.overlays import OVERLAYS
from lab.ui.ownership import ControlOwnership
from lab.ui.panel import ControlPanel
from lab.ui.phase_portrait_plot import add_phase_portrait_plot
from lab.ui.plots import Plots
from lab.ui.recording import RecordingControls
from lab.ui.scene_view import SceneView
from lab.ui.velocity_controls import HOTKEYS, STOP_HOTKEY

PLOT_PANEL_PX = 400  # width of the plots panel docked left of the 3-D view
SLOW_COMMAND_S = 1.0  # a command answered later than this is logged (the lab answers in ms)
# Commands after which the panels re-read `info` to show what the server holds, accepted or not
# (a walking gait may also install a walking stack).
INFO_CHANGING_VERBS = frozenset(
    ("stack", "gains", "hierarchy", "robot", "scene", "reset", "pause", "resume", "gait")
)
# The server zeroes the velocity command on these commands (docs/protocol.md).
MOTION_ENDING_VERBS = frozenset(("reset", "robot", "scene"))
SWITCH_WAIT_S = 3.0  # for a command in flight to the lab the page switches away from
READ_ONLY = "this browser is read-only: press Take control"
P = ParamSpec("P")


def _yaw(quat_xyzw: list[float]) -> float:
    x, y, z, w = quat_xyzw
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class LabApp:
    """The viser server, its shared widgets, the browsers' panels and the link to the lab."""

    def __init__(
        self,
        http_port: int,
        endpoint: str,
        host: str = "127.0.0.1",
        stop: threading.Event | None = None,
        lab_id: str | None = None,
    ) -> None:
        self.server = viser.ViserServer(host=host, port=http_port, label="WBC lab", verbose=False)
        self.server.gui.configure_theme(control_width="large", dark_mode=False)
        # No image-based lighting: viser draws the whole canvas at 5 % opacity until its HDR
        # environment map has loaded and decoded, which took up to a minute in software WebGL on
        # a busy machine (the robot "faded" after the page loaded). Plain lights draw at once.
        self.server.scene.configure_environment_map(None)
        self.server.scene.configure_default_lights(enabled=True, cast_shadow=False)
        try:  # waits for a sim that is still starting, unless `stop` is set meanwhile
            self.link = Link(endpoint, stop.is_set if stop is not None else lambda: False, lab_id)
        except zenoh.ZError:
            self.server.stop()
            raise
        self.ownership = ControlOwnership()
        self.lab_lock = LabLock(self.link.client_id, self.link.request)
        self.info: dict | None = None
        self.telemetry: dict | None = None
        self.wanted_lab: str | None = None  # a browser's switch, done by the render loop
        self.panels: dict[int, ControlPanel] = {}
        self._lock = threading.RLock()
        # `show_info` runs on the render loop and on viser's callback threads (a click that
        # changes the world, then `refresh_info`): one shows its `info` at a time, or one panel
        # part (the hand gizmos) reads what another call is replacing.
        self._showing_info = threading.Lock()
        self._sender = ThreadPoolExecutor(max_workers=1, thread_name_prefix="lab-ui-send")
        self.pending: Future | None = None  # the stream command in flight (velocity, drag)
        self.velocity = VelocityCommand()  # the one the render loop resends while non-zero
        self.drag = DragPush()
        self.scene = SceneView(self.server, self.guard(self._on_drag))
        self.log = EventLog()
        self._log_shown = -1
        # the last hierarchy switch: (monotonic s, "cascade → weighted", telemetry before it)
        self.switch: tuple[float, str, dict] | None = None

        gui = self.server.gui
        self.status = gui.add_markdown("Waiting for the lab server…", order=0)
        install_hotkey_script(gui, "".join(HOTKEYS) + STOP_HOTKEY)
        with gui.add_folder("Event log", order=7):
            self.log_filter = gui.add_dropdown(
                "Show", (ALL, *CATEGORIES), initial_value=ALL, hint="one kind of event only"
            )
            self.log_view = gui.add_markdown(self.log.markdown())
        self.log_filter.on_update(lambda _: self.show_log(force=True))
        with gui.add_folder("Overlays", order=10):
            for name in OVERLAYS:
                box = gui.add_checkbox(name, self.scene.overlay_visible[name])
                box.on_update(lambda e, n=name: self.scene.toggle_overlay(n, e.target.value))
        # The charts are read while pushing: their own panel docked left of the 3-D view, the
        # controls docked right of it, so that both stay in sight, the robot between them.
        self.plot_panel = gui.add_panel()
        plots_tab = self.plot_panel.add_tab("Plots", viser.Icon.CHART_LINE)
        self.plots = Plots(gui, plots_tab, self.guard, self.server.atomic)
        self.plots.charts.append(add_internal_force_plot(gui, plots_tab, self.server.atomic))
        self.plots.charts += add_phase_portrait_plot(gui, plots_tab)
        self.plot_panel.dock_left()
        self.plot_panel.set_width(PLOT_PANEL_PX)
        gui.main_panel.dock_right()
        self.recording = RecordingControls(gui, self.send, self.guard)
        self.server.on_client_connect(self.guard(self._connect))
        self.server.on_client_disconnect(self.guard(self._disconnect))

    # ---- errors and the event log -------------------------------------------------------------
    def guard(self, callback: Callable[P, object]) -> Callable[P, None]:
        """`callback` for a viser event: an exception in it is shown in the page and logged, and
        the UI keeps serving (viser would only print it)."""

        @functools.wraps(callback)
        def guarded(*args: P.args, **kwargs: P.kwargs) -> None:
            try:
                callback(*args, **kwargs)
            except Exception as error:  # any bug in a callback: report it, keep serving
                self.report_exception(getattr(callback, "__name__", "callback"), error)

        return guarded

    def report_exception(self, where: str, error: Exception) -> None:
        """An exception in the UI process: into the event log and the UI's output, not fatal."""
        print(f"lab ui: error in {where}:", flush=True)
        traceback.print_exception(error)
        text = f"UI error in {where}: {type(error).__name__}: {error}"
        self.report("error", text, category="fault")

    def report(
        self,
        level: str,
        text: str,
        client: viser.ClientHandle | None = None,
        category: str | None = None,
    ) -> None:
        """Add a line to the page's event log (in `category`; by default a refusal for an error
        or warning, else info); with `client`, also pop it up in that browser."""
        self.log.add(level, text, category=category or ("info" if level == "info" else "refusal"))
        if client is not None:
            colour = {"error": "red", "warning": "yellow"}.get(level, "blue")
            title = text.split(":", 1)[0] if ":" in text else level.capitalize()
            client.add_notification(
                title, text, color=colour, auto_close_seconds=8.0, with_close_button=True
            )

    def show_log(self, force: bool = False) -> None:
        """Show the event log's new lines (all of them again with `force`)."""
        if force or self.log.version != self._log_shown:
            self._log_shown = self.log.version
            self.log_view.content = self.log.markdown(self.log_filter.value)

    def notify_error(self, client: viser.ClientHandle, verb: str, error: str) -> None:
        print(f"lab ui: {verb} from browser {client.client_id} not applied: {error}", flush=True)
        self.report("error", f"{verb} rejected: {error}", client)

    # ---- browsers and control ----------------------------------------------------------------
    def each_panel(self) -> list[ControlPanel]:
        """The panels of the browsers connected now (a copy: browsers come and go meanwhile)."""
        with self._lock:
            return list(self.panels.values())

    def _connect(self, client: viser.ClientHandle) -> None:
        client.camera.position = (1.6, -1.6, 1.1)
        client.camera.look_at = (0.0, 0.0, 0.3)
        panel = ControlPanel(self, client)
        with self._lock:
            self.panels[client.client_id] = panel
            self.ownership.claim_if_free(client.client_id)
        if self.info is not None:
            panel.show_info(self.info)
        panel.labs.show(self.link.directory.labs(), self.link.lab_id)
        self.show_ownership()

    def _disconnect(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self.panels.pop(client.client_id, None)
            if self.ownership.release(client.client_id):
                self._stop_motion()
                if self.panels:
                    self.ownership.take(min(self.panels))
            nobody = self.ownership.owner is None
        if nobody:  # no browser holds control: neither does the page hold the lab's lock
            self.lab_lock.release()
        self.show_ownership()

    def take_control(self, client_id: int) -> None:
        """Browser `client_id` takes control of the page and, for it, the lab's control lock
        (refused, naming the holder, while another client holds it)."""
        with self._lock:
            if self.ownership.take(client_id) != client_id:
                self._stop_motion()
            panel = self.panels.get(client_id)
        if panel is not None and not self.replaying():
            error = self.lab_lock.acquire()
            if error is not None:
                self.notify_error(panel.client, "take control", error)
        self.show_ownership()

    def show_ownership(self) -> None:
        """Every panel shows who holds control: which browser, or another client of the lab."""
        for panel in self.each_panel():
            panel.show_ownership(self.ownership.owner, self.lab_lock.other())

    def _may_act(self, client: viser.ClientHandle, verb: str) -> bool:
        """Whether `client` may send `verb` now: it holds control and, for a command that
        changes the world, the page holds the lab's lock (taken now if free). A refusal is
        shown to the browser."""
        if not self.ownership.is_owner(client.client_id):
            self.notify_error(client, verb, READ_ONLY)
            return False
        if verb in READ_ONLY_VERBS or self.replaying():
            return True
        error = self.lab_lock.acquire()
        if error is None:
            return True
        self.notify_error(client, verb, error)
        self.show_ownership()
        return False

    def replaying(self) -> bool:
        """Whether the lab is a recording (`lab replay --serve`: no lock to take)."""
        info = self.info
        return info is not None and "replay" in info

    def switch_lab(self, client: viser.ClientHandle, lab_id: str) -> None:
        """Show and drive lab `lab_id` from now on, for every browser (the render loop
        switches); refused for a browser that does not hold control."""
        if not self.ownership.is_owner(client.client_id):
            self.notify_error(client, "lab", READ_ONLY)
            return
        self.wanted_lab = lab_id

    def select_lab(self, lab_id: str) -> None:
        """Leave the lab watched for `lab_id` (the render loop's switch): the command in
        flight arrives first, the old lab stops now (not at its deadman) and gets its lock
        back."""
        if self.pending is not None:  # a velocity or drag push on its way to the old lab
            futures.wait([self.pending], SWITCH_WAIT_S)
        if not self.velocity.is_zero:
            self.link.send(VelocityCommand())
        self.velocity, self.drag.grab = VelocityCommand(), None
        self.lab_lock.release()
        self.link.select(lab_id)
        self.lab_lock.forget()

    def zero_velocity(self) -> None:
        """Forget the velocity command (the server zeroed it: Reset, a switch, a fall) so that
        the page stops resending it, and show zero in every panel."""
        self.velocity, self.drag.grab = VelocityCommand(), None
        for panel in self.each_panel():
            panel.velocity_controls.zero()

    def _stop_motion(self) -> None:
        self.drag.grab = None
        if not self.velocity.is_zero:
            self.velocity = VelocityCommand()
            self.send_background(self.velocity)

    # ---- commands ----------------------------------------------------------------------------
    def send(self, client: viser.ClientHandle, verb: str, payload: dict) -> dict | None:
        """Send a command for `client` if it may act (`_may_act`); report a rejection to it."""
        if not self._may_act(client, verb):
            return None
        if verb in MOTION_ENDING_VERBS:  # the server zeroes the velocity: so does the page
            self.zero_velocity()
            pending = self.pending  # a refresh on its way must not arrive after the command
            if pending is not None:
                futures.wait([pending], SWITCH_WAIT_S)
        sent = time.monotonic()
        before, info = self.telemetry, self.info
        reply = self.link.request(verb, payload)
        if time.monotonic() - sent > SLOW_COMMAND_S:
            print(f"lab ui: {verb} took {time.monotonic() - sent:.1f} s to answer", flush=True)
        if not reply.get("ok"):
            self.notify_error(client, verb, str(reply.get("error", "rejected")))
        elif verb == "hierarchy" and before is not None and info is not None:
            old, new = info["hierarchy"]["method"], reply["hierarchy"]["method"]
            self.switch = (time.monotonic(), f"{old} → {new}", before)
        if verb in INFO_CHANGING_VERBS:
            self.refresh_info()
        return reply

    def refresh_info(self) -> bool:
        """Ask the lab for `info` and show it in every panel; whether it answered."""
        reply = self.link.request("info")
        if not reply.get("ok"):
            return False
        self.show_info(reply)
        return True

    def show_info(self, info: dict) -> None:
        """Hold `info` and show it in every panel, one call at a time."""
        with self._showing_info:
            self.info = info
            if self.lab_lock.seen(info):
                self.show_ownership()
            for panel in self.each_panel():
                panel.show_info(info)

    def set_velocity(self, client: viser.ClientHandle, cmd: VelocityCommand) -> None:
        """Send `cmd` for `client` and resend it while non-zero (the render loop); a read-only
        browser's pad and keys send nothing, silently."""
        if not self.ownership.is_owner(client.client_id) or not self._may_act(client, "velocity"):
            return
        self.velocity = cmd
        self.send_background(cmd)

    def send_background(self, command: CommandStruct) -> None:
        """Fire-and-forget for streams (velocity refresh, drag push): skip if one is in flight."""
        if self.pending is not None and not self.pending.done():
            return
        self.pending = self._sender.submit(self.link.send, command)

    def base_yaw(self) -> float:
        return 0.0 if self.telemetry is None else _yaw(self.telemetry["base"]["quaternion"])

    def base_body(self) -> str:
        """The floating base link, the body the push buttons push."""
        if self.info and self.info.get("base"):
            return self.info["base"]
        return self.info["bodies"][0] if self.info and self.info["bodies"] else "base"

    def _on_drag(self, event: viser.SceneNodeDragEvent, link: str) -> None:
        """A drag on the robot's link `link`: the render loop pushes along it while it lasts."""
        robot = self.scene.robot_view
        if not self.ownership.is_owner(event.client_id) or robot is None:
            return
        if event.phase == "start" and not self._may_act(event.client, "push"):
            return
        body = link if self.info and link in self.info["bodies"] else self.base_body()
        start, pointer = np.array(event.start_position), np.array(event.end_position)
        self.drag.move(event.phase, start, pointer, body, robot)
        if event.phase == "end" and self.scene.overlays is not None:
            self.scene.overlays.show_drag(None, None)

    def close(self) -> None:
        """Stop the workers, give the lab its lock back, close the link and the server."""
        self.scene.close()
        self._sender.shutdown(wait=True)
        self.lab_lock.release()
        self.link.close()
        self.server.stop()
