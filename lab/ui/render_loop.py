"""The page's render loop: what the app does with each message from the lab, frame by frame.

One thread runs `RenderLoop.run`: it drains the lab's channels (state at ~60 Hz, telemetry,
events), draws the robot (`scene_view.py`), overlays (30 Hz), plots (20 Hz) and the status line
(5 Hz), follows the labs coming and going and the link to the one watched, resends a non-zero
velocity and an active drag push before the deadman ends them, and logs what the server
reports. The app (`app.py`) holds what the browsers' callbacks share with it.
"""

import threading
import time
import traceback
from dataclasses import dataclass

import numpy as np

from lab.ui.app import LabApp
from lab.ui.event_log import log_server_event
from lab.ui.guard_rails import error_growth
from lab.ui.overlays import Overlays
from lab.ui.status import LiveStatus, started_warnings

FRAME_S = 1.0 / 60.0  # render loop period: state arrives at ~60 Hz
PLOT_S = 1.0 / 20.0  # plot redraw period
OVERLAY_S = 1.0 / 30.0  # overlay redraw period
STATUS_S = 0.2
REFRESH_S = 0.2  # resend a non-zero velocity (deadman 0.5 s) and an active drag push
ERROR_RETRY_S = 1.0  # after an exception in the render loop, wait this long before the next frame
# The server zeroes the velocity command on these events (docs/protocol.md).
MOTION_ENDING_EVENTS = frozenset(("reset", "session_rebuilt", "fall", "sim_diverged"))
# s (wall): a fall this soon after a hierarchy switch is explained in the log by what it changed
SWITCH_BLAME_S = 10.0
DISCONNECTED = (
    "the lab server (sim process) is not reachable: stopped, crashed, or the network link to it "
    "broke. The page shows the last state it had and reconnects by itself when the server is back."
)


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


class RenderLoop:
    """The render loop of `app` (see the module docstring)."""

    def __init__(self, app: LabApp) -> None:
        self.app = app
        self._lost_at: float | None = None  # wall time the sim process was last seen to vanish
        self._seen_alive = False
        self._watched_lab: str | None = None  # the lab whose telemetry the page shows
        self._live = LiveStatus()  # the status line's recent figures
        self._draw_fps = 0.0
        self._warnings: set[str] = set()  # kinds of status warnings in effect

    def run(self, stop: threading.Event) -> None:
        """Draw state, overlays, plots and status until `stop` is set. An exception in one
        frame is shown in the page and the loop goes on."""
        app = self.app
        while not stop.is_set():
            self._watch_labs()
            if app.refresh_info():
                break
            app.status.content = (
                "Waiting for the lab server (no reply to `info`)…"
                if app.link.lab_id is not None
                else "Waiting for a lab (sim process) to appear…"
            )
            stop.wait(0.5)
        clock = _FrameClock(time.monotonic())
        while not stop.is_set():
            try:
                watched = self._frame(time.monotonic(), clock)
            except Exception as error:  # a bug in one frame must not end the UI
                if viser_wakeup_race(error):  # viser's, not ours: the frame is redrawn next time
                    app.report(
                        "warning",
                        "a frame was dropped: viser's message wake-up raced its event loop "
                        "(a viser thread-safety issue; the next frame redraws everything)",
                        category="fault",
                    )
                    continue
                app.report_exception("the render loop", error)
                app.show_log()
                stop.wait(ERROR_RETRY_S)
                clock.next_frame = time.monotonic()
                continue
            clock.next_frame += FRAME_S if watched else 0.0
            delay = clock.next_frame - time.monotonic() if watched else FRAME_S
            if delay > 0:
                stop.wait(delay)
            else:
                clock.next_frame = time.monotonic()

    def _frame(self, now: float, clock: _FrameClock) -> bool:
        """One pass of the render loop; whether a browser is watching."""
        app, scene = self.app, self.app.scene
        scene.finish_loading(app.report_exception)
        self._watch_labs()
        self._watch_link()
        tel = self._take_telemetry()  # plots keep recording while nobody watches
        state = app.link.latest_state()
        # With no browser connected only a robot switch is drawn: the UI then costs the
        # machine almost nothing, and the sim loop beside it keeps its schedule.
        watched = bool(app.server.get_clients())
        if (
            state is not None
            and (watched or state["robot"] != scene.robot_name)
            and scene.draw_state(state)  # another robot: no drag on the old one, its `info`
        ):
            app.drag.grab = None
            app.refresh_info()
        if not watched:
            return False
        if tel is not None:
            self._log_status_changes(tel)
        # From the newest telemetry, not this frame's: a recording that ended before a browser
        # came sends no more, and its scene (the floor) was never drawn.
        latest = app.telemetry
        if (
            latest is not None
            and latest["robot"] == scene.robot_name
            and latest["scene"] != scene.scene_name
        ):
            scene.show_scene(latest["scene"])
        overlays = scene.overlays
        if tel is not None and overlays is not None and now - clock.overlay >= OVERLAY_S:
            clock.overlay = now
            self._overlay_frame(tel, overlays)
        self._handle_events()
        if now - clock.refresh >= REFRESH_S:
            clock.refresh = now
            self._refresh_motion()
        if now - clock.plot >= PLOT_S:
            clock.plot = now
            app.plots.draw()
        if now - clock.status >= STATUS_S:
            drawn = scene.frames_drawn
            self._draw_fps = (drawn - clock.frames_at_status) / (now - clock.status)
            clock.frames_at_status, clock.status = drawn, now
            app.status.content = self._status_text()
            if app.telemetry is not None:
                app.recording.show(app.telemetry)
            app.show_log()
        return True

    def _overlay_frame(self, tel: dict, overlays: Overlays) -> None:
        """The overlays, the joystick pads and the panels' velocity from telemetry `tel`;
        `info` read anew when someone else changed the stack or the gait."""
        app, scene = self.app, self.app.scene
        info = app.info
        if info is not None and (tel["stack"], tel["gait"]) != (info["stack"], info["gait"]):
            self._follow_stack_and_gait(info, tel)
        view = scene.robot_view  # a view built but not yet posed has no frames to look up
        if tel["robot"] == scene.robot_name and view is not None and view.drawn:
            overlays.update(tel)
        position = np.array(tel["base"]["position"])
        for panel in app.each_panel():
            panel.follow_robot(position, app.base_yaw())
            panel.velocity_controls.show_command(tel["command"])

    def _refresh_motion(self) -> None:
        """Resend the drag push in progress, or a non-zero velocity, before the lab ends it."""
        app, scene = self.app, self.app.scene
        robot = scene.robot_view
        drag = app.drag.command(robot) if robot is not None else None
        if drag is not None:
            push, grab, pointer = drag
            if scene.overlays is not None:
                scene.overlays.show_drag(grab, pointer)
            app.send_background(push)
        elif not app.velocity.is_zero:
            app.send_background(app.velocity)

    def _watch_labs(self) -> None:
        """Follow the labs coming and going, switch to the one a browser chose, and list them
        in every panel."""
        app = self.app
        app.link.poll_labs()
        wanted, app.wanted_lab = app.wanted_lab, None
        if wanted is not None and wanted != app.link.lab_id:
            app.select_lab(wanted)
        if app.link.lab_id != self._watched_lab:
            self._watched_lab = app.link.lab_id
            app.telemetry, app.switch = None, None
            self._lost_at, self._seen_alive, self._live = None, False, LiveStatus()
            app.log.add("info", f"showing lab {self._watched_lab}")
            app.plots.clear()
            app.refresh_info()
        labs = app.link.directory.labs()
        for panel in app.each_panel():
            panel.labs.show(labs, app.link.lab_id)

    def _take_telemetry(self) -> dict | None:
        """Every telemetry message since the last frame into the plots and the status figures;
        the newest, or None. A change of the control lock's holder is shown and logged."""
        app = self.app
        batch = app.link.telemetry()
        for tel in batch:
            app.plots.record(tel)
            self._live.add(tel)
        if not batch:
            return None
        tel = batch[-1]
        app.telemetry = tel
        run = (app.link.lab_id, tel["robot"], tel["scene"])
        self._live.add_newest(time.monotonic(), tel, run, live=not app.replaying())
        before = app.lab_lock.other()
        if app.lab_lock.seen(tel):
            self._log_lock_holder(before)
            app.show_ownership()
        return tel

    def _log_lock_holder(self, before: str | None) -> None:
        """Log another client taking the lab's control lock, or giving it up."""
        other = self.app.lab_lock.other()
        if other is not None:
            text = (
                f"client {other} holds the lab's control lock: this page reads only until it "
                "is released (Take control asks for it)"
            )
            self.app.log.add("warning", text, category="refusal")
        else:
            self.app.log.add("info", f"client {before} no longer holds the lab's control lock")

    def _watch_link(self) -> None:
        """Log the sim process vanishing and coming back; on its return, read its `info` anew
        (it may be a new process with another robot)."""
        app = self.app
        connected, was_lost = app.link.poll_connected(), self._lost_at is not None
        self._seen_alive |= connected
        if connected != was_lost or not self._seen_alive:  # no change, or not yet found once
            return
        if was_lost:
            self._lost_at = None
            app.log.add("info", "the lab server is back: reconnected")
            app.refresh_info()
        else:
            self._lost_at = time.time()
            app.log.add("error", DISCONNECTED, category="fault")

    def _status_text(self) -> str:
        app, loading = self.app, self.app.scene.loading
        if self._lost_at is not None:
            since = time.strftime("%H:%M:%S", time.localtime(self._lost_at))
            return f"**Disconnected** since {since}: {DISCONNECTED}"
        if loading is not None:
            return (
                f"**Loading {loading.robot}** ({loading.elapsed():.0f} s): its meshes "
                "are converted on first use, then read from a cache…  \n…  \n…"
            )
        if app.telemetry is None:
            return "Waiting for telemetry from the lab server…"
        if app.scene.robot_view is None:
            return f"**{app.telemetry['robot']}** could not be drawn: see the event log"
        return self._live.markdown(app.telemetry, self._draw_fps)

    def _follow_stack_and_gait(self, info: dict, tel: dict) -> None:
        """Someone else changed the stack or the gait: read `info` anew. A recording's `info`
        is the one recorded at its start: its stack and gait are then taken from telemetry
        (asked again every frame, the gait dropdown disagreed with the status line)."""
        if "replay" not in info:
            self.app.refresh_info()
        else:
            self.app.show_info({**info, "stack": tel["stack"], "gait": tel["gait"]})

    def _handle_events(self) -> None:
        app = self.app
        for event in app.link.events():
            kind = event.get("type", "?")
            log_server_event(app.log, event)
            if kind == "fall" and app.switch is not None and app.telemetry is not None:
                switched, what, before = app.switch
                if time.monotonic() - switched < SWITCH_BLAME_S:
                    app.log.add(
                        "warning",
                        f"the fall came {time.monotonic() - switched:.1f} s after the hierarchy "
                        f"switch {what}; task errors that grew most: "
                        f"{error_growth(before, app.telemetry)}",
                        category="fall",
                    )
            if kind in MOTION_ENDING_EVENTS:
                app.zero_velocity()
            if kind in ("session_rebuilt", "reset"):
                app.refresh_info()

    def _log_status_changes(self, tel: dict) -> None:
        """A warning of the status line (slow ticks, fallbacks, a fall) into the log when it
        starts."""
        now = self._live.warnings(tel)
        for kind, text in started_warnings(now, self._warnings):
            self.app.log.add("warning", f"t {tel['t']:.2f} s · {text}", kind=kind)
        self._warnings = set(now)
