"""The 3-D scene the page draws: the robot (its view and overlays) and the terrain.

A robot's view is built on a worker thread (converting meshes on a cold cache takes tens of
seconds) while the page stays live and the status line reads "Loading"; the render loop then
shows it (`finish_loading`) and poses it from each `lab/state` message (`draw_state`).
"""

import time
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass

import viser

from lab.description import load_description
from lab.ui.overlays import OVERLAYS, Overlays
from lab.ui.robot_view import RobotView
from lab.ui.terrain_view import TerrainView

# `on_drag(event, link)` for a drag on one of the robot's links
DragCallback = Callable[[viser.SceneNodeDragEvent, str], None]


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


class SceneView:
    """The robot and terrain drawn in `server`'s scene; `on_drag` gets drags on the robot."""

    def __init__(self, server: viser.ViserServer, on_drag: DragCallback) -> None:
        self.server = server
        self._on_drag = on_drag
        self.robot_name: str | None = None  # the robot drawn or being loaded
        self.scene_name: str | None = None
        self.robot_view: RobotView | None = None
        self.overlays: Overlays | None = None
        self.terrain: TerrainView | None = None
        self.overlay_visible = {name: name != "friction cones" for name in OVERLAYS}
        self._loader = ThreadPoolExecutor(max_workers=1, thread_name_prefix="lab-ui-load")
        self.loading: _Loading | None = None  # the robot whose view is being built
        self.frames_drawn = 0

    def toggle_overlay(self, name: str, visible: bool) -> None:
        self.overlay_visible[name] = visible
        if self.overlays is not None:
            self.overlays.set_visible(name, visible)

    def load_robot(self, name: str) -> None:
        """Start replacing the drawn robot by `name`'s (built on the loader thread). The name
        is taken first: a robot that fails to load is reported once, not retried every frame."""
        self.robot_name = name
        for old in (self.overlays, self.robot_view):
            if old is not None:
                old.remove()
        self.robot_view = self.overlays = None
        if self.loading is not None:  # a newer switch: drop the older robot once it is built
            self.loading.job.add_done_callback(_remove_built)
        job = self._loader.submit(self._build_robot, name)
        self.loading = _Loading(name, time.monotonic(), job)

    def _build_robot(self, name: str) -> tuple[RobotView, Overlays]:
        """The view and overlays of robot `name` (on the loader thread)."""
        desc = load_description(name)
        view = RobotView(self.server, desc, on_drag=self._on_drag)
        overlays = Overlays(
            self.server, desc.contacts, desc.friction,
            lambda frame: view.frame_placement(frame).rotation().as_matrix(),
        )  # fmt: skip
        for overlay, visible in self.overlay_visible.items():
            overlays.set_visible(overlay, visible)
        return view, overlays

    def finish_loading(self, report: Callable[[str, Exception], None]) -> None:
        """Show the robot whose view the loader has built, or `report(where, error)` why it
        could not be."""
        loading = self.loading
        if loading is None or not loading.job.done():
            return
        self.loading = None
        try:
            self.robot_view, self.overlays = loading.job.result()
        except Exception as error:  # a robot that cannot be drawn: the page says so
            report(f"loading {loading.robot}", error)
            return
        print(f"lab ui: {loading.robot} loaded in {loading.elapsed():.1f} s", flush=True)

    def show_scene(self, name: str) -> None:
        """Draw scene `name`'s terrain in place of the one drawn (taken first: a failing scene
        is not retried)."""
        self.scene_name = name
        if self.terrain is not None:
            self.terrain.remove()
            self.terrain = None
        self.terrain = TerrainView(self.server, name)

    def draw_state(self, state: dict) -> bool:
        """Pose the robot and the moving terrain from a `lab/state` message; whether it names
        another robot (its load has started: the caller reads `info` anew)."""
        switched = state["robot"] != self.robot_name
        if switched:
            self.load_robot(state["robot"])
        if self.terrain is not None and "scene_bodies" in state:  # moving terrain, where it is
            self.terrain.set_poses(state["scene_bodies"])
        if self.robot_view is not None:
            self.robot_view.set_state(state["frames"])
            self.server.flush()  # send this pose now rather than at viser's next 60 Hz window
            self.frames_drawn += 1
        return switched

    def close(self) -> None:
        self._loader.shutdown(wait=True, cancel_futures=True)
