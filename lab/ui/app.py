"""The browser lab: a viser server that draws what the sim process publishes and sends commands.

It talks to the sim process only through Zenoh (`lab.ui.link`); it reads robot descriptions and
scene builders (static data) but never imports the controller or the session.
"""

import math
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np
import viser

from lab.description import load_description
from lab.ui.drag_push import Spring, spring_force
from lab.ui.joystick import VelocityCommand
from lab.ui.link import Link
from lab.ui.overlays import OVERLAYS, Overlays
from lab.ui.ownership import ControlOwnership
from lab.ui.panel import ControlPanel
from lab.ui.plots import Plots
from lab.ui.robot_view import RobotView
from lab.ui.terrain_view import TerrainView

FRAME_S = 1.0 / 60.0  # render loop period: state arrives at ~60 Hz
PLOT_S = 1.0 / 20.0  # plot redraw period
OVERLAY_S = 1.0 / 30.0  # overlay redraw period
STATUS_S = 0.2
SLOW_COMMAND_S = 1.0  # a command answered later than this is logged (the lab answers in ms)
REFRESH_S = 0.2  # resend a non-zero velocity (deadman 0.5 s) and an active drag push
DRAG_PUSH_S = 0.25  # duration of each drag push; refreshed every REFRESH_S while dragging
# Commands after which the panels re-read `info` to show what the server holds, accepted or not
# (a walking gait may also install a walking stack).
INFO_CHANGING_VERBS = frozenset(
    ("stack", "gains", "hierarchy", "robot", "scene", "reset", "pause", "resume", "gait")
)


def _yaw(quat_xyzw: list[float]) -> float:
    x, y, z, w = quat_xyzw
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class LabApp:
    def __init__(self, http_port: int, endpoint: str, host: str = "127.0.0.1") -> None:
        self.server = viser.ViserServer(host=host, port=http_port, label="WBC lab", verbose=False)
        self.server.gui.configure_theme(control_width="large", dark_mode=False)
        self.link = Link(endpoint)
        self.ownership = ControlOwnership()
        self.info: dict | None = None
        self.telemetry: dict | None = None
        self.panels: dict[int, ControlPanel] = {}
        self._lock = threading.RLock()
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
        self._rtf_window: list[tuple[float, float]] = []
        self.frames_drawn = 0
        self._draw_fps = 0.0
        self._last_error = ""

        gui = self.server.gui
        self.status = gui.add_markdown("Waiting for the lab server…", order=0)
        with gui.add_folder("Overlays", order=10):
            for name in OVERLAYS:
                box = gui.add_checkbox(name, name != "friction cones")
                self._overlay_visible[name] = box.value
                box.on_update(lambda e, n=name: self._toggle_overlay(n, e.target.value))
        self._plot_folder = gui.add_folder("Plots", order=11)
        self.plots = Plots(gui, self._plot_folder)
        self.server.on_client_connect(self._connect)
        self.server.on_client_disconnect(self._disconnect)

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

    def _stop_motion(self) -> None:
        self._drag = None
        if not self._velocity.is_zero:
            self._velocity = VelocityCommand()
            self._send_background("velocity", self._velocity.payload())

    # ---- commands ----------------------------------------------------------------------------
    def send(self, client: viser.ClientHandle, verb: str, payload: dict) -> dict | None:
        """Send a command for `client` if it holds control; report a rejection to it."""
        if not self.ownership.is_owner(client.client_id):
            self.notify_error(client, verb, "this browser is read-only: press Take control")
            return None
        sent = time.monotonic()
        reply = self.link.request(verb, payload)
        if time.monotonic() - sent > SLOW_COMMAND_S:
            print(f"lab ui: {verb} took {time.monotonic() - sent:.1f} s to answer", flush=True)
        if not reply.get("ok"):
            self.notify_error(client, verb, str(reply.get("error", "rejected")))
        if verb in INFO_CHANGING_VERBS:
            self.refresh_info()
        return reply

    def notify_error(self, client: viser.ClientHandle, verb: str, error: str) -> None:
        self._last_error = f"{verb}: {error}"
        print(f"lab ui: {verb} from browser {client.client_id} not applied: {error}", flush=True)
        client.add_notification(
            f"Rejected: {verb}", error, color="red", auto_close_seconds=6.0, with_close_button=True
        )

    def refresh_info(self) -> bool:
        reply = self.link.request("info")
        if not reply.get("ok"):
            return False
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
        self._send_background("velocity", cmd.payload())

    def _send_background(self, verb: str, payload: dict) -> None:
        """Fire-and-forget for streams (velocity refresh, drag push): skip if one is in flight."""
        if self._pending is not None and not self._pending.done():
            return
        self._pending = self._sender.submit(self.link.request, verb, payload)

    def base_yaw(self) -> float:
        return 0.0 if self.telemetry is None else _yaw(self.telemetry["base"]["quaternion"])

    def base_body(self) -> str:
        """The floating base link, the body the push buttons push."""
        if self.robot_view is not None:
            return self.robot_view.root_link
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
            local = self.robot_view.frame_placement(body).actInv(np.array(event.start_position))
            self._drag = (body, local, pointer)
        else:
            self._drag = (self._drag[0], self._drag[1], pointer)

    def _drag_push(self) -> None:
        if self._drag is None or self.robot_view is None:
            return
        body, local, pointer = self._drag
        grab = self.robot_view.frame_placement(body).act(local)
        force = spring_force(grab, pointer, self._spring)
        if self.overlays is not None:
            self.overlays.show_drag(grab, pointer)
        payload = {"body": body, "force": force.tolist(), "duration": DRAG_PUSH_S}
        payload["point"] = grab.tolist()
        self._send_background("push", payload)

    # ---- drawing -----------------------------------------------------------------------------
    def _toggle_overlay(self, name: str, visible: bool) -> None:
        self._overlay_visible[name] = visible
        if self.overlays is not None:
            self.overlays.set_visible(name, visible)

    def _load_robot(self, name: str) -> None:
        desc = load_description(name)
        for old in (self.overlays, self.robot_view):
            if old is not None:
                old.remove()
        self.robot_view = RobotView(
            self.server, desc.urdf_path, desc.package_dirs, on_drag=self._on_drag,
            srdf=desc.srdf_path, posture=desc.posture,
        )  # fmt: skip
        view = self.robot_view
        self.overlays = Overlays(
            self.server, desc.contacts, desc.friction,
            lambda frame: view.frame_placement(frame).rotation,
        )  # fmt: skip
        for overlay, visible in self._overlay_visible.items():
            self.overlays.set_visible(overlay, visible)
        self._robot_name = name
        self._drag = None

    def _load_scene(self, name: str, friction: float) -> None:
        if self.terrain is not None:
            self.terrain.remove()
        self.terrain = TerrainView(self.server, name, friction)
        self._scene_name = name

    def _draw_state(self, state: dict) -> None:
        if state["robot"] != self._robot_name:
            self._load_robot(state["robot"])
            self.refresh_info()
        joints = dict(zip(state["joints"]["names"], state["joints"]["positions"], strict=True))
        self.robot_view.set_state(state["base"]["position"], state["base"]["quaternion"], joints)
        self.server.flush()  # send this pose now rather than at viser's next 60 Hz window
        self.frames_drawn += 1

    def _take_telemetry(self) -> dict | None:
        batch = self.link.telemetry()
        for tel in batch:
            self.plots.record(tel)
        if not batch:
            return None
        tel = batch[-1]
        self.telemetry = tel
        self._rtf_window.append((time.monotonic(), tel["t"]))
        while len(self._rtf_window) > 2 and self._rtf_window[0][0] < time.monotonic() - 2.0:
            self._rtf_window.pop(0)
        return tel

    def _realtime_factor(self) -> float:
        if len(self._rtf_window) < 2:
            return float("nan")
        (w0, t0), (w1, t1) = self._rtf_window[0], self._rtf_window[-1]
        return (t1 - t0) / (w1 - w0) if w1 > w0 else float("nan")

    def _status_text(self) -> str:
        tel = self.telemetry
        if tel is None:
            return "Waiting for telemetry from the lab server…"
        loop = tel.get("loop", {})
        qp = tel["qp"]
        flags = " · **paused**" if tel["paused"] else ""
        flags += " · **fell**: torques off until Reset" if tel["fell"] else ""
        hierarchy = tel["hierarchy"]
        method = hierarchy["method"]
        if method == "nullspace":
            method += f" ({hierarchy['formulation']})"
        text = (
            f"**{tel['robot']}** on {tel['scene']} · {tel['gait']} · {method}/"
            f"{hierarchy['solver']}{flags}  \n"
            f"t {tel['t']:.2f} s · RTF {self._realtime_factor():.2f} · on-time "
            f"{100.0 * loop.get('on_time_fraction', float('nan')):.2f} % · QP "
            f"{qp['solve_us']:.0f} µs ({qp['status']}) · failures {qp['failures']} · view "
            f"{self._draw_fps:.0f} fps"
        )
        if self._last_error:
            text += f"  \nLast error: {self._last_error}"
        return text

    def _handle_events(self) -> None:
        for event in self.link.events():
            if event["type"] == "rejected_command":
                self._last_error = f"{event.get('verb', '?')}: {event.get('error', '')}"
            elif event["type"] in ("fall", "solver_failure"):
                self._last_error = event["message"]
            if event["type"] in ("session_rebuilt", "reset"):
                self.refresh_info()

    def run(self, stop: threading.Event) -> None:
        """The render loop: draw state, overlays, plots and status until `stop` is set."""
        while not stop.is_set() and not self.refresh_info():
            self.status.content = "Waiting for the lab server (no reply to `info`)…"
            stop.wait(0.5)
        last_plot = last_refresh = last_overlay = 0.0
        last_status, frames_at_status = time.monotonic(), 0
        next_frame = time.monotonic()
        while not stop.is_set():
            now = time.monotonic()
            tel = self._take_telemetry()  # plots keep recording while nobody watches
            state = self.link.latest_state()
            # With no browser connected only a robot switch is drawn: the UI then costs the
            # machine almost nothing, and the sim loop beside it keeps its schedule.
            watched = bool(self.server.get_clients())
            if state is not None and (watched or state["robot"] != self._robot_name):
                self._draw_state(state)
            if not watched:
                stop.wait(FRAME_S)
                continue
            if tel is not None and self.overlays is not None and now - last_overlay >= OVERLAY_S:
                last_overlay = now
                if (tel["scene"], tel["robot"]) != (self._scene_name, self._robot_name) and (
                    tel["robot"] == self._robot_name
                ):
                    self._load_scene(tel["scene"], load_description(tel["robot"]).friction)
                info = self.info
                if info is not None and (tel["stack"], tel["gait"]) != (
                    info["stack"],
                    info["gait"],
                ):
                    self.refresh_info()  # someone else changed the stack or the gait
                self.overlays.update(tel)
                position = np.array(tel["base"]["position"])
                with self._lock:
                    panels = list(self.panels.values())
                for panel in panels:
                    panel.follow_robot(position, self.base_yaw())
                    panel.show_command(tel["command"])
            self._handle_events()
            if now - last_refresh >= REFRESH_S:
                last_refresh = now
                if self._drag is not None:
                    self._drag_push()
                elif not self._velocity.is_zero:
                    self._send_background("velocity", self._velocity.payload())
            if now - last_plot >= PLOT_S:
                last_plot = now
                self.plots.draw()
            if now - last_status >= STATUS_S:
                self._draw_fps = (self.frames_drawn - frames_at_status) / (now - last_status)
                frames_at_status, last_status = self.frames_drawn, now
                self.status.content = self._status_text()
            next_frame += FRAME_S
            delay = next_frame - time.monotonic()
            if delay > 0:
                stop.wait(delay)
            else:
                next_frame = time.monotonic()

    def close(self) -> None:
        self._sender.shutdown(wait=True)
        self.link.close()
        self.server.stop()
