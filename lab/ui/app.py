"""The browser lab: a viser server that draws what the sim process publishes and sends commands.

It talks to the sim process only through Zenoh (`lab.ui.link`, `lab.protocol`); it reads robot
descriptions (TOML, URDF visuals) and scene geometry, all plain data, and imports neither the
controller, pinocchio nor MuJoCo (tests/ui/test_ui_logic.py checks).

Over 400 lines because the render loop, the browsers' control and the command path share the
app's state (telemetry, info, velocity, ownership); what does not is kept apart: the status
figures (`status.LiveStatus`), the event log and the server events' kinds (`event_log`), the
plots, overlays, robot and terrain views, and each browser's panel.
"""

import functools
import math
import threading
import time
import traceback
from collections.abc import Callable
from concurrent import futures
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import ParamSpec

import numpy as np
import viser
import zenoh

from lab.description import load_description
from lab.protocol import CommandStruct, PushCommand, VelocityCommand
from lab.ui.drag_push import Spring, spring_force
from lab.ui.event_log import ALL, CATEGORIES, EventLog, log_server_event
from lab.ui.guard_rails import error_growth
from lab.ui.hotkeys import install_hotkey_script
from lab.ui.internal_force_plot import add_internal_force_plot
from lab.ui.link import Link
from lab.ui.overlays import OVERLAYS, Overlays
from lab.ui.ownership import ControlOwnership
from lab.ui.panel import HOTKEYS, STOP_HOTKEY, ControlPanel
from lab.ui.phase_portrait_plot import add_phase_portrait_plot
from lab.ui.plots import Plots
from lab.ui.recording import RecordingControls
from lab.ui.robot_view import RobotView
from lab.ui.status import LiveStatus, started_warnings
from lab.ui.terrain_view import TerrainView

FRAME_S = 1.0 / 60.0  # render loop period: state arrives at ~60 Hz
PLOT_S = 1.0 / 20.0  # plot redraw period
OVERLAY_S = 1.0 / 30.0  # overlay redraw period
PLOT_PANEL_PX = 400  # width of the plots panel docked left of the 3-D view
STATUS_S = 0.2
SLOW_COMMAND_S = 1.0  # a command answered later than this is logged (the lab answers in ms)
REFRESH_S = 0.2  # resend a non-zero velocity (deadman 0.5 s) and an active drag push
DRAG_PUSH_S = 0.25  # duration of each drag push; refreshed every REFRESH_S while dragging
# Commands after which the panels re-read `info` to show what the server holds, accepted or not
# (a walking gait may also install a walking stack).
INFO_CHANGING_VERBS = frozenset(
    ("stack", "gains", "hierarchy", "robot", "scene", "reset", "pause", "resume", "gait")
)
# The server zeroes the velocity command on these commands and events (docs/protocol.md).
MOTION_ENDING_VERBS = frozenset(("reset", "robot", "scene"))
MOTION_ENDING_EVENTS = frozenset(("reset", "session_rebuilt", "fall", "sim_diverged"))
ERROR_RETRY_S = 1.0  # after an exception in the render loop, wait this long before the next frame
# s (wall): a fall this soon after a hierarchy switch is explained in the log by what it changed
SWITCH_BLAME_S = 10.0
SWITCH_WAIT_S = 3.0  # for a command in flight to the lab the page switches away from
DISCONNECTED = (
    "the lab server (sim process) is not reachable: stopped, crashed, or the network link to it "
    "broke. The page shows the last state it had and reconnects by itself when the server is back."
)
P = ParamSpec("P")


def viser_wakeup_race(error: Exception) -> bool:
    """Whether `error` is viser's known race: a scene update from this thread pushes its
    message, then sets an asyncio.Event that viser's event-loop thread may be iterating at that
    moment (viser/infra/_async_message_buffer.py sets it "both inside and outside of the event
    loop"). The message is already queued; only the rest of this frame is lost."""
    if not (isinstance(error, RuntimeError) and str(error) == "deque mutated during iteration"):
        return False
    frames = traceback.extract_tb(error.__traceback__)
    return any(f.filename.endswith("_async_message_buffer.py") for f in frames)


@dataclass
class _FrameClock:
    """When the render loop last did each of its periodic jobs (monotonic s)."""

    next_frame: float
    overlay: float = 0.0
    refresh: float = 0.0
    plot: float = 0.0
    status: float = 0.0
    frames_at_status: int = 0


@dataclass
class _Loading:
    """A robot whose view the loader thread is building."""

    robot: str
    started: float  # monotonic s
    job: Future

    def elapsed(self) -> float:
        return time.monotonic() - self.started


def _remove_built(job: Future) -> None:
    """Remove the view and overlays a superseded load built."""
    if job.exception() is None:
        for built in job.result():
            built.remove()


def _yaw(quat_xyzw: list[float]) -> float:
    x, y, z, w = quat_xyzw
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class LabApp:
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
        self.info: dict | None = None
        self.telemetry: dict | None = None
        self._lost_at: float | None = None  # wall time the sim process was last seen to vanish
        self._seen_alive = False
        self._watched_lab: str | None = None  # the lab whose telemetry the page shows
        self._wanted_lab: str | None = None  # a browser's switch, done by the render loop
        self.panels: dict[int, ControlPanel] = {}
        self._lock = threading.RLock()
        # `refresh_info` runs on the render loop and on viser's callback threads (a click that
        # changes the world): one shows its reply at a time, or one panel part (the hand
        # gizmos) reads what another call is replacing.
        self._showing_info = threading.Lock()
        self._sender = ThreadPoolExecutor(max_workers=1, thread_name_prefix="lab-ui-send")
        self._pending: Future | None = None
        self._robot_name: str | None = None
        self._scene_name: str | None = None
        self.robot_view: RobotView | None = None
        self.overlays: Overlays | None = None
        self.terrain: TerrainView | None = None
        self._overlay_visible: dict[str, bool] = {}
        self._velocity = VelocityCommand()
        self._drag: tuple[str, np.ndarray, np.ndarray] | None = None  # link, local point, pointer
        self._spring = Spring()
        self._live = LiveStatus()  # the status line's recent figures
        self.frames_drawn = 0
        self._draw_fps = 0.0
        self._loader = ThreadPoolExecutor(max_workers=1, thread_name_prefix="lab-ui-load")
        self._loading: _Loading | None = None  # the robot whose view is being built
        self.log = EventLog()
        self._warnings: set[str] = set()  # kinds of status warnings in effect
        self._log_shown = -1
        # the last hierarchy switch: (monotonic s, "cascade → weighted", telemetry before it)
        self._switch: tuple[float, str, dict] | None = None

        gui = self.server.gui
        self.status = gui.add_markdown("Waiting for the lab server…", order=0)
        install_hotkey_script(gui, "".join(HOTKEYS) + STOP_HOTKEY)
        with gui.add_folder("Event log", order=7):
            self.log_filter = gui.add_dropdown(
                "Show", (ALL, *CATEGORIES), initial_value=ALL, hint="one kind of event only"
            )
            self.log_view = gui.add_markdown(self.log.markdown())
        self.log_filter.on_update(lambda _: self._show_log(force=True))
        with gui.add_folder("Overlays", order=10):
            for name in OVERLAYS:
                box = gui.add_checkbox(name, name != "friction cones")
                self._overlay_visible[name] = box.value
                box.on_update(lambda e, n=name: self._toggle_overlay(n, e.target.value))
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

    def _show_log(self, force: bool = False) -> None:
        if force or self.log.version != self._log_shown:
            self._log_shown = self.log.version
            self.log_view.content = self.log.markdown(self.log_filter.value)

    # ---- browsers and control ----------------------------------------------------------------
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
        self._show_ownership()

    def _disconnect(self, client: viser.ClientHandle) -> None:
        with self._lock:
            self.panels.pop(client.client_id, None)
            if self.ownership.release(client.client_id):
                self._stop_motion()
                if self.panels:
                    self.ownership.take(min(self.panels))
        self._show_ownership()

    def take_control(self, client_id: int) -> None:
        with self._lock:
            if self.ownership.take(client_id) != client_id:
                self._stop_motion()
        self._show_ownership()

    def _show_ownership(self) -> None:
        with self._lock:
            panels = list(self.panels.values())
        for panel in panels:
            panel.show_ownership(self.ownership.owner)

    def switch_lab(self, client: viser.ClientHandle, lab_id: str) -> None:
        """Show and drive lab `lab_id` from now on, for every browser (the render loop
        switches); refused for a browser that does not hold control."""
        if not self.ownership.is_owner(client.client_id):
            self.notify_error(client, "lab", "this browser is read-only: press Take control")
            return
        self._wanted_lab = lab_id

    def _watch_labs(self) -> None:
        """Follow the labs coming and going, switch to the one a browser chose, and list them
        in every panel."""
        self.link.poll_labs()
        wanted, self._wanted_lab = self._wanted_lab, None
        if wanted is not None and wanted != self.link.lab_id:
            if self._pending is not None:  # a velocity or drag push on its way to the old lab
                futures.wait([self._pending], SWITCH_WAIT_S)
            if not self._velocity.is_zero:  # the lab left behind stops now, not at its deadman
                self.link.send(VelocityCommand())
            self._velocity, self._drag = VelocityCommand(), None
            self.link.select(wanted)
        if self.link.lab_id != self._watched_lab:
            self._watched_lab = self.link.lab_id
            self.telemetry, self._lost_at, self._seen_alive, self._switch = None, None, False, None
            self._live = LiveStatus()
            self.log.add("info", f"showing lab {self._watched_lab}")
            self.plots.clear()
            self.refresh_info()
        labs = self.link.directory.labs()
        with self._lock:
            panels = list(self.panels.values())
        for panel in panels:
            panel.labs.show(labs, self.link.lab_id)

    def _zero_velocity(self) -> None:
        """Forget the velocity command (the server zeroed it: Reset, a switch, a fall) so that
        the page stops resending it, and show zero in every panel."""
        self._velocity, self._drag = VelocityCommand(), None
        with self._lock:
            panels = list(self.panels.values())
        for panel in panels:
            panel.zero_velocity()

    def _stop_motion(self) -> None:
        self._drag = None
        if not self._velocity.is_zero:
            self._velocity = VelocityCommand()
            self._send_background(self._velocity)

    # ---- commands ----------------------------------------------------------------------------
    def send(self, client: viser.ClientHandle, verb: str, payload: dict) -> dict | None:
        """Send a command for `client` if it holds control; report a rejection to it."""
        if not self.ownership.is_owner(client.client_id):
            self.notify_error(client, verb, "this browser is read-only: press Take control")
            return None
        if verb in MOTION_ENDING_VERBS:  # the server zeroes the velocity: so does the page
            self._zero_velocity()
            pending = self._pending  # a refresh on its way must not arrive after the command
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
            self._switch = (time.monotonic(), f"{old} → {new}", before)
        if verb in INFO_CHANGING_VERBS:
            self.refresh_info()
        return reply

    def notify_error(self, client: viser.ClientHandle, verb: str, error: str) -> None:
        print(f"lab ui: {verb} from browser {client.client_id} not applied: {error}", flush=True)
        self.report("error", f"{verb} rejected: {error}", client)

    def refresh_info(self) -> bool:
        reply = self.link.request("info")
        if not reply.get("ok"):
            return False
        with self._showing_info:
            self.info = reply
            with self._lock:
                panels = list(self.panels.values())
            for panel in panels:
                panel.show_info(reply)
        return True

    def set_velocity(self, client: viser.ClientHandle, cmd: VelocityCommand) -> None:
        if not self.ownership.is_owner(client.client_id):
            return
        self._velocity = cmd
        self._velocity_sent = time.monotonic()
        self._send_background(cmd)

    def _send_background(self, command: CommandStruct) -> None:
        """Fire-and-forget for streams (velocity refresh, drag push): skip if one is in flight."""
        if self._pending is not None and not self._pending.done():
            return
        self._pending = self._sender.submit(self.link.send, command)

    def base_yaw(self) -> float:
        return 0.0 if self.telemetry is None else _yaw(self.telemetry["base"]["quaternion"])

    def base_body(self) -> str:
        """The floating base link, the body the push buttons push."""
        if self.info and self.info.get("base"):
            return self.info["base"]
        return self.info["bodies"][0] if self.info and self.info["bodies"] else "base"

    # ---- drag push ---------------------------------------------------------------------------
    def _on_drag(self, event: viser.SceneNodeDragEvent, link: str) -> None:
        if not self.ownership.is_owner(event.client_id) or self.robot_view is None:
            return
        if event.phase == "end":
            self._drag = None
            if self.overlays is not None:
                self.overlays.show_drag(None, None)
            return
        pointer = np.array(event.end_position)
        if event.phase == "start" or self._drag is None or self._drag[0] != link:
            body = link if self.info and link in self.info["bodies"] else self.base_body()
            local = (
                self.robot_view.frame_placement(body)
                .inverse()
                .apply(np.array(event.start_position))
            )
            self._drag = (body, local, pointer)
        else:
            self._drag = (self._drag[0], self._drag[1], pointer)

    def _drag_push(self) -> None:
        if self._drag is None or self.robot_view is None:
            return
        body, local, pointer = self._drag
        grab = self.robot_view.frame_placement(body).apply(local)
        force = spring_force(grab, pointer, self._spring)
        if self.overlays is not None:
            self.overlays.show_drag(grab, pointer)
        fx, fy, fz = force.tolist()
        x, y, z = grab.tolist()
        self._send_background(PushCommand(body, (fx, fy, fz), DRAG_PUSH_S, (x, y, z)))

    # ---- drawing -----------------------------------------------------------------------------
    def _toggle_overlay(self, name: str, visible: bool) -> None:
        self._overlay_visible[name] = visible
        if self.overlays is not None:
            self.overlays.set_visible(name, visible)

    def _load_robot(self, name: str) -> None:
        """Start replacing the drawn robot: its view is built on a worker thread (converting
        meshes on a cold cache takes tens of seconds) while the page stays live and the status
        line reads "Loading". The name is taken first: a robot that fails to load is reported
        once, not retried every frame."""
        self._robot_name, self._drag = name, None
        for old in (self.overlays, self.robot_view):
            if old is not None:
                old.remove()
        self.robot_view = self.overlays = None
        if self._loading is not None:  # a newer switch: drop the older robot once it is built
            self._loading.job.add_done_callback(_remove_built)
        job = self._loader.submit(self._build_robot, name)
        self._loading = _Loading(name, time.monotonic(), job)

    def _build_robot(self, name: str) -> tuple[RobotView, Overlays]:
        """The view and overlays of robot `name` (on the loader thread)."""
        desc = load_description(name)
        view = RobotView(self.server, desc, on_drag=self.guard(self._on_drag))
        overlays = Overlays(
            self.server, desc.contacts, desc.friction,
            lambda frame: view.frame_placement(frame).rotation().as_matrix(),
        )  # fmt: skip
        for overlay, visible in self._overlay_visible.items():
            overlays.set_visible(overlay, visible)
        return view, overlays

    def _finish_loading(self) -> None:
        """Show the robot whose view the loader has built, or report why it could not be."""
        loading = self._loading
        if loading is None or not loading.job.done():
            return
        self._loading = None
        try:
            self.robot_view, self.overlays = loading.job.result()
        except Exception as error:  # a robot that cannot be drawn: the page says so
            self.report_exception(f"loading {loading.robot}", error)
            return
        print(f"lab ui: {loading.robot} loaded in {loading.elapsed():.1f} s", flush=True)

    def _load_scene(self, name: str) -> None:
        if self.terrain is not None:
            self.terrain.remove()
            self.terrain = None
        self.terrain = TerrainView(self.server, name)

    def _draw_state(self, state: dict) -> None:
        if state["robot"] != self._robot_name:
            self._load_robot(state["robot"])
            self.refresh_info()
        if self.terrain is not None and "scene_bodies" in state:  # moving terrain, where it is
            self.terrain.set_poses(state["scene_bodies"])
        if self.robot_view is None:
            return
        self.robot_view.set_state(state["frames"])
        self.server.flush()  # send this pose now rather than at viser's next 60 Hz window
        self.frames_drawn += 1

    def _take_telemetry(self) -> dict | None:
        batch = self.link.telemetry()
        for tel in batch:
            self.plots.record(tel)
            self._live.add(tel)
        if not batch:
            return None
        tel = batch[-1]
        self.telemetry = tel
        run = (self.link.lab_id, tel["robot"], tel["scene"])
        self._live.add_newest(time.monotonic(), tel, run)
        return tel

    def _watch_link(self) -> None:
        """Log the sim process vanishing and coming back; on its return, read its `info` anew
        (it may be a new process with another robot)."""
        connected, was_lost = self.link.poll_connected(), self._lost_at is not None
        self._seen_alive |= connected
        if connected != was_lost or not self._seen_alive:  # no change, or not yet found once
            return
        if was_lost:
            self._lost_at = None
            self.log.add("info", "the lab server is back: reconnected")
            self.refresh_info()
        else:
            self._lost_at = time.time()
            self.log.add("error", DISCONNECTED, category="fault")

    def _status_text(self) -> str:
        if self._lost_at is not None:
            since = time.strftime("%H:%M:%S", time.localtime(self._lost_at))
            return f"**Disconnected** since {since}: {DISCONNECTED}"
        if self._loading is not None:
            return (
                f"**Loading {self._loading.robot}** ({self._loading.elapsed():.0f} s): its meshes "
                "are converted on first use, then read from a cache…  \n…  \n…"
            )
        if self.telemetry is None:
            return "Waiting for telemetry from the lab server…"
        if self.robot_view is None:
            return f"**{self.telemetry['robot']}** could not be drawn: see the event log"
        return self._live.markdown(self.telemetry, self._draw_fps)

    def _follow_stack_and_gait(self, info: dict, tel: dict) -> None:
        """Someone else changed the stack or the gait: read `info` anew. A recording's `info`
        is the one recorded at its start: its stack and gait are then taken from telemetry
        (asked again every frame, the gait dropdown disagreed with the status line)."""
        if "replay" not in info:
            self.refresh_info()
            return
        self.info = {**info, "stack": tel["stack"], "gait": tel["gait"]}
        with self._lock:
            panels = list(self.panels.values())
        for panel in panels:
            panel.show_info(self.info)

    def _handle_events(self) -> None:
        for event in self.link.events():
            kind = event.get("type", "?")
            log_server_event(self.log, event)
            if kind == "fall" and self._switch is not None and self.telemetry is not None:
                switched, what, before = self._switch
                if time.monotonic() - switched < SWITCH_BLAME_S:
                    self.log.add(
                        "warning",
                        f"the fall came {time.monotonic() - switched:.1f} s after the hierarchy "
                        f"switch {what}; task errors that grew most: "
                        f"{error_growth(before, self.telemetry)}",
                        category="fall",
                    )
            if kind in MOTION_ENDING_EVENTS:
                self._zero_velocity()
            if kind in ("session_rebuilt", "reset"):
                self.refresh_info()

    def _log_status_changes(self, tel: dict) -> None:
        """A warning of the status line (slow ticks, fallbacks, a fall) into the log when it
        starts."""
        now = self._live.warnings(tel)
        for kind, text in started_warnings(now, self._warnings):
            self.log.add("warning", f"t {tel['t']:.2f} s · {text}", kind=kind)
        self._warnings = set(now)

    def run(self, stop: threading.Event) -> None:
        """The render loop: draw state, overlays, plots and status until `stop` is set. An
        exception in one frame is shown in the page and the loop goes on."""
        while not stop.is_set():
            self._watch_labs()
            if self.refresh_info():
                break
            self.status.content = (
                "Waiting for the lab server (no reply to `info`)…"
                if self.link.lab_id is not None
                else "Waiting for a lab (sim process) to appear…"
            )
            stop.wait(0.5)
        clock = _FrameClock(time.monotonic())
        while not stop.is_set():
            try:
                watched = self._frame(time.monotonic(), clock)
            except Exception as error:  # a bug in one frame must not end the UI
                if viser_wakeup_race(error):  # viser's, not ours: the frame is redrawn next time
                    self.report(
                        "warning",
                        "a frame was dropped: viser's message wake-up raced its event loop "
                        "(a viser thread-safety issue; the next frame redraws everything)",
                        category="fault",
                    )
                    continue
                self.report_exception("the render loop", error)
                self._show_log()
                stop.wait(ERROR_RETRY_S)
                clock.next_frame = time.monotonic()
                continue
            clock.next_frame += FRAME_S if watched else 0.0
            delay = clock.next_frame - time.monotonic() if watched else FRAME_S
            if delay > 0:
                stop.wait(delay)
            else:
                clock.next_frame = time.monotonic()

    def _frame(self, now: float, clock: "_FrameClock") -> bool:
        """One pass of the render loop; whether a browser is watching."""
        self._finish_loading()
        self._watch_labs()
        self._watch_link()
        tel = self._take_telemetry()  # plots keep recording while nobody watches
        state = self.link.latest_state()
        # With no browser connected only a robot switch is drawn: the UI then costs the
        # machine almost nothing, and the sim loop beside it keeps its schedule.
        watched = bool(self.server.get_clients())
        if state is not None and (watched or state["robot"] != self._robot_name):
            self._draw_state(state)
        if not watched:
            return False
        if tel is not None:
            self._log_status_changes(tel)
        # From the newest telemetry, not this frame's: a recording that ended before a browser
        # came sends no more, and its scene (the floor) was never drawn.
        latest = self.telemetry
        robot, scene = (None, None) if latest is None else (latest["robot"], latest["scene"])
        if robot is not None and robot == self._robot_name and scene != self._scene_name:
            self._scene_name = scene  # taken first: a failing scene is not retried
            self._load_scene(scene)
        if tel is not None and self.overlays is not None and now - clock.overlay >= OVERLAY_S:
            clock.overlay = now
            info = self.info
            if info is not None and (tel["stack"], tel["gait"]) != (info["stack"], info["gait"]):
                self._follow_stack_and_gait(info, tel)
            view = self.robot_view  # a view built but not yet posed has no frames to look up
            if tel["robot"] == self._robot_name and view is not None and view.drawn:
                self.overlays.update(tel)
            position = np.array(tel["base"]["position"])
            with self._lock:
                panels = list(self.panels.values())
            for panel in panels:
                panel.follow_robot(position, self.base_yaw())
                panel.show_command(tel["command"])
        self._handle_events()
        if now - clock.refresh >= REFRESH_S:
            clock.refresh = now
            if self._drag is not None:
                self._drag_push()
            elif not self._velocity.is_zero:
                self._send_background(self._velocity)
        if now - clock.plot >= PLOT_S:
            clock.plot = now
            self.plots.draw()
        if now - clock.status >= STATUS_S:
            self._draw_fps = (self.frames_drawn - clock.frames_at_status) / (now - clock.status)
            clock.frames_at_status, clock.status = self.frames_drawn, now
            self.status.content = self._status_text()
            if self.telemetry is not None:
                self.recording.show(self.telemetry)
            self._show_log()
        return True

    def close(self) -> None:
        self._loader.shutdown(wait=True, cancel_futures=True)
        self._sender.shutdown(wait=True)
        self.link.close()
        self.server.stop()
