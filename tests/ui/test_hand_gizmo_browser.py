"""A hand gizmo dragged with the mouse in a real headless Chromium against `lab serve --robot
talos_arms` (issue 29): the drag reaches the lab as the hand's new target, and the hand follows
it (the `hands` task's tracking error, up at the drag, shrinks again).

The gizmo is found where the page draws it: its node in viser's scene (`__viserMutable`, which
viser exposes for its own end-to-end tests), one point on its x arrow and one further along it
projected through the page's camera to the canvas.
"""

import threading
import time
from pathlib import Path

import numpy as np
import pytest

from lab.ui.hand_gizmos import GIZMO_SCALE
from tests.helpers.browser import CHROMIUM, CHROMIUM_ARGS, LabServe
from tests.helpers.hands import HAND_STACK

playwright_api = pytest.importorskip("playwright.sync_api")

pytestmark = [pytest.mark.browser]
VIEWPORT = {"width": 1400, "height": 800}
LOAD_TIMEOUT_MS = 180_000  # Talos's meshes on a cold cache, a busy machine (test_ui_browser)
DRAG_M = 0.08  # how far along the gizmo's x arrow the mouse drags the target
# The screen points (CSS px) of points `along` m out on the gizmo's x arrow (its local frame:
# the hand's target), through the page's camera.
ARROW_POINTS = """([name, along]) => {
  const m = window.__viserMutable, node = m.nodeRefFromName[name];
  const box = document.querySelector("canvas").getBoundingClientRect();
  node.updateWorldMatrix(true, false);
  return along.map(a => {
    const p = node.localToWorld(node.position.clone().set(a, 0, 0)).project(m.camera);
    return [box.left + (p.x + 1) / 2 * box.width, box.top + (1 - p.y) / 2 * box.height];
  });
}"""


def _hands_error(tel: dict) -> float:
    """The `hands` task's tracking error (both hands' position and rotation errors, norm)."""
    return next(t["error"] for t in tel["tasks"] if t["name"] == "hands")


def _left_target(lab) -> np.ndarray:
    hands = lab.command("info")["hands"]
    return np.array(next(h["position"] for h in hands if h["name"] == "left"))


def test_a_dragged_hand_gizmo_moves_the_target_and_the_hand_follows(tmp_path: Path) -> None:
    if not Path(CHROMIUM).exists():
        pytest.skip(f"no Chromium at {CHROMIUM} (./dev test installs Debian's chromium)")
    serve = LabServe(tmp_path / "serve.log", "--robot", "talos_arms")
    try:
        with serve.client() as lab:
            assert lab.command("stack", levels=HAND_STACK)["ok"]  # the page holds no lock yet
            settled = _hands_error(lab.wait_telemetry(lambda m: m["t"] > 2.0, timeout=120.0))
            before = _left_target(lab)
            errors: list[tuple[float, float]] = []  # (sim s, the hands' error) from the drag on
            dragging = threading.Event()
            # subscribed long before the drag: a subscriber just declared misses what the server
            # publishes before it knows of it, and the peak comes within a second of the drag
            lab.subscribe_telemetry(
                lambda m: errors.append((m["t"], _hands_error(m))) if dragging.is_set() else None
            )
            serve.wait_ui()
            with playwright_api.sync_playwright() as p:
                browser = p.chromium.launch(
                    executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS
                )
                page = browser.new_page(viewport=VIEWPORT)
                page.set_default_timeout(60_000)
                page.goto(serve.url)
                # the page's panel is built after Talos's view: meshes on a cold cache
                page.get_by_text("You hold control").wait_for(timeout=LOAD_TIMEOUT_MS)
                loading = page.get_by_text("Loading")
                playwright_api.expect(loading).to_have_count(0, timeout=LOAD_TIMEOUT_MS)
                page.wait_for_function(
                    "() => window.__viserMutable?.nodeRefFromName?.['/hands/left'] != null"
                )
                page.wait_for_timeout(2000)  # the camera has settled on the robot
                along = [0.6 * GIZMO_SCALE, 0.6 * GIZMO_SCALE + DRAG_M]
                (x0, y0), (x1, y1) = page.evaluate(ARROW_POINTS, ["/hands/left", along])
                dragging.set()
                page.mouse.move(x0, y0)
                page.mouse.down()
                for f in (0.3, 0.7, 1.0):  # quick: the target runs ahead of the hand
                    page.mouse.move(x0 + f * (x1 - x0), y0 + f * (y1 - y0))
                    page.wait_for_timeout(60)
                page.mouse.up()
                end = time.monotonic() + 30.0
                after = _left_target(lab)
                while np.linalg.norm(after - before) < 0.5 * DRAG_M and time.monotonic() < end:
                    time.sleep(0.2)
                    after = _left_target(lab)
                moved = after - before
                browser.close()
            # the target moved along the gizmo's x arrow (the target's x: world x at rest)
            assert 0.5 * DRAG_M < moved[0] < 1.5 * DRAG_M, moved
            # mostly along it: the mouse's path is a projection of the arrow, read mid-drag
            assert abs(moved[0]) > 2.0 * max(abs(moved[1]), abs(moved[2])), moved
            # the hand lagged the new target, then caught up with it
            peak_t, peak = max(list(errors), key=lambda sample: sample[1])
            late = lab.wait_telemetry(lambda m: m["t"] > peak_t + 3.0, timeout=120.0)
            assert not late["fell"]
            assert peak > settled + 0.25 * DRAG_M, (settled, peak)
            caught_up = _hands_error(late)
            assert caught_up < 0.5 * peak and caught_up < settled + 0.25 * DRAG_M, (
                settled,
                peak,
                caught_up,
            )
    finally:
        serve.stop()
