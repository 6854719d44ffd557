"""The browser lab in a real headless Chromium against a real `lab serve` (sim + UI processes).

One server and one browser are shared by the tests in file order (ANYmal first, the robot switch
last) to keep the file to about a minute.
"""

import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from browser import CHROMIUM, CHROMIUM_ARGS, LabServe

from lab.client import LabClient
from lab.stack_presets import load_stack_preset

playwright_api = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.browser
PAGE_TIMEOUT_MS = 60_000
# s: from a click in the page to its effect in telemetry or `info`. A second or less when idle;
# generous because on a loaded 2-core machine the browser and the UI process share what is left.
UI_ACTION_TIMEOUT_S = 30.0
VIEWPORT = {"width": 1100, "height": 700}


@pytest.fixture(scope="module")
def serve(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LabServe]:
    srv = LabServe(tmp_path_factory.mktemp("ui") / "serve.log", "--robot", "anymal")
    yield srv
    srv.stop()


@pytest.fixture(scope="module")
def lab(serve: LabServe) -> Iterator[LabClient]:
    client = serve.client()
    yield client
    client.close()


@pytest.fixture(scope="module")
def browser() -> Iterator[object]:
    if not Path(CHROMIUM).exists():
        pytest.skip(f"no Chromium at {CHROMIUM} (./dev test installs Debian's chromium)")
    with playwright_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def page(browser, serve: LabServe, lab: LabClient):
    context = browser.new_context(viewport=VIEWPORT)
    pg = context.new_page()
    pg.set_default_timeout(PAGE_TIMEOUT_MS)
    frames: list[float] = []
    pg.on("websocket", lambda ws: ws.on("framereceived", lambda _: frames.append(time.monotonic())))
    serve.wait_ui()
    pg.goto(serve.url)
    pg.get_by_text("You hold control").wait_for()
    pg.ws_frames = frames
    yield pg
    context.close()


def dark_pixels(pg) -> int:
    """Pixels of the 3-D view (left of the control panel) darker than the floor and grid lines:
    the robot's meshes and their shadows."""
    import io

    from PIL import Image

    shot = np.asarray(Image.open(io.BytesIO(pg.screenshot())).convert("L"))
    view = shot[150:, : int(shot.shape[1] * 0.65)]
    return int((view < 90).sum())


def wait_dark_pixels(pg, predicate, timeout: float = 30.0) -> int:
    """Poll `dark_pixels` until `predicate` holds (viser fades new meshes in) or time is up."""
    end = time.monotonic() + timeout
    n = dark_pixels(pg)
    while not predicate(n) and time.monotonic() < end:
        pg.wait_for_timeout(500)
        n = dark_pixels(pg)
    return n


def choose(pg, label: str, option: str) -> None:
    pg.get_by_label(label, exact=True).first.click(no_wait_after=True)
    pg.get_by_role("option", name=option, exact=True).click(no_wait_after=True)


def test_page_loads_and_draws_the_live_robot(page, lab: LabClient) -> None:
    page.get_by_text("anymal", exact=True).first.wait_for()
    t0 = time.monotonic()
    n0 = len(page.ws_frames)
    page.wait_for_timeout(2000)  # lets playwright dispatch the websocket events
    rate = (len(page.ws_frames) - n0) / (time.monotonic() - t0)
    # Liveness, not speed: a stalled UI sends nothing, a live one streams every pose it draws.
    # The rate itself is a benchmark number (docs/performance.md: 23-30 frames/s with software
    # WebGL on a busy 2-core machine), never a test threshold.
    assert rate >= 5.0, f"UI updates arrive at {rate:.1f} frames/s: the view is not live"
    assert wait_dark_pixels(page, lambda n: n > 1500) > 1500  # the robot is drawn in the view
    page.get_by_text("RTF").wait_for()  # status line from live telemetry


def test_push_button_moves_the_base_in_the_pushed_direction(
    page, lab: LabClient, serve: LabServe
) -> None:
    tel = lab.wait_telemetry(lambda m: not m["fell"], timeout=5.0)
    yaw_ok = abs(tel["base"]["quaternion"][2]) < 0.1  # heading ~ world x: "left" is world +y
    assert yaw_ok, tel["base"]["quaternion"]
    page.get_by_role("button", name="left", exact=True).click(no_wait_after=True)
    try:
        peak = lab.wait_telemetry(
            lambda m: m["base"]["linear_velocity"][1] > 0.1, timeout=UI_ACTION_TIMEOUT_S
        )
    except TimeoutError as error:  # seen once in ten runs: keep what the page and server saw
        page.screenshot(path=str(serve.log.with_name("push_timeout.png")))
        time.sleep(5.0)  # a late "took N s to answer" line from the UI process
        raise AssertionError(f"no push arrived; lab serve said:\n{serve.output()}") from error
    vx, vy, _ = peak["base"]["linear_velocity"]
    assert vy > 0.1 and vy > abs(vx), peak["base"]["linear_velocity"]


def test_moving_a_task_in_the_stack_editor_is_acknowledged(page, lab: LabClient) -> None:
    before = lab.command("info")["stack"]
    task = before[-1][0]  # a task of the lowest level
    choose(page, "Task", task)
    page.get_by_role("button", name="▲ level", exact=True).click(no_wait_after=True)
    expected_level = len(before) - 2  # into the level above (the last one vanishes if emptied)
    end = time.monotonic() + UI_ACTION_TIMEOUT_S
    stack = before
    while time.monotonic() < end:
        stack = lab.command("info")["stack"]
        if stack != before:
            break
        time.sleep(0.1)
    assert task in stack[expected_level], (before, stack)
    level_text = ", ".join(stack[expected_level])  # the editor shows the acknowledged stack
    page.get_by_text(level_text.replace(task, f"[{task}]"), exact=True).wait_for()


def test_a_second_browser_is_read_only_until_it_takes_control(browser, serve, page) -> None:
    context = browser.new_context(viewport=VIEWPORT)
    second = context.new_page()
    second.set_default_timeout(PAGE_TIMEOUT_MS)
    second.goto(serve.url)
    second.get_by_text("Read-only").wait_for()
    assert second.get_by_role("button", name="Stop").is_disabled()
    assert second.get_by_label("Gait", exact=True).first.is_disabled()
    assert second.get_by_role("button", name="Load preset").is_disabled()
    assert second.get_by_role("button", name="front", exact=True).count() == 0
    second.get_by_role("button", name="Take control").click(no_wait_after=True)
    second.get_by_text("You hold control").wait_for()
    page.get_by_text("Read-only").wait_for()
    assert page.get_by_role("button", name="Stop").is_disabled()
    page.get_by_role("button", name="Take control").click(no_wait_after=True)
    page.get_by_text("You hold control").wait_for()
    context.close()


def heading_speed(window_s: float, start: dict):
    """A telemetry predicate: true once the base's mean velocity along its heading over the last
    `window_s` of sim time exceeds 0.1 m/s; raises if the robot falls or 5 s of sim pass."""
    samples: list[tuple[float, np.ndarray]] = []

    def moving(tel: dict) -> bool:
        assert not tel["fell"], "the robot fell"
        assert tel["t"] - start["t"] < 5.0, f"no forward walk within 5 s of sim: {samples[-1]}"
        samples.append((tel["t"], np.array(tel["base"]["position"][:2])))
        while len(samples) > 2 and samples[-1][0] - samples[1][0] >= window_s:
            samples.pop(0)
        (t0, p0), (t1, p1) = samples[0], samples[-1]
        qx, qy, qz, qw = tel["base"]["quaternion"]
        yaw = np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        heading = np.array([np.cos(yaw), np.sin(yaw)])
        return t1 - t0 >= window_s and heading @ (p1 - p0) / (t1 - t0) > 0.1

    return moving


def test_trot_from_the_gait_dropdown_walks_forward(page, lab: LabClient) -> None:
    choose(page, "Gait", "trot")
    tel = lab.wait_telemetry(lambda m: m["gait"] == "trot", timeout=UI_ACTION_TIMEOUT_S)
    assert "swing_feet" in {name for level in tel["stack"] for name in level}  # walking stack
    page.get_by_text("swing_feet").first.wait_for()  # the stack editor shows it
    page.evaluate("document.activeElement && document.activeElement.blur()")
    page.keyboard.press("i")  # velocity hotkeys: two taps, 0.3 m/s forward
    page.keyboard.press("i")
    start = lab.wait_telemetry(lambda m: m["command"]["vx"] > 0.25, timeout=UI_ACTION_TIMEOUT_S)
    walked = lab.wait_telemetry(heading_speed(1.0, start), timeout=60.0)
    assert walked["gait"] == "trot" and not walked["fell"]
    page.keyboard.press("x")
    page.get_by_role("button", name="Reset", exact=True).click(no_wait_after=True)
    # Only a reset turns trot into stand ("t < 1" could pass unseen by a starved test process).
    lab.wait_telemetry(lambda m: m["gait"] == "stand", timeout=UI_ACTION_TIMEOUT_S)


def test_loading_a_stack_preset_is_acknowledged(page, lab: LabClient) -> None:
    preset = load_stack_preset("raiola_s1")
    choose(page, "Preset", "raiola_s1")
    page.get_by_role("button", name="Load preset", exact=True).click(no_wait_after=True)
    end = time.monotonic() + UI_ACTION_TIMEOUT_S
    info = lab.command("info")
    while info["stack"] != preset.levels and time.monotonic() < end:
        time.sleep(0.1)
        info = lab.command("info")
    assert info["stack"] == preset.levels
    assert info["hierarchy"]["method"] == preset.hierarchy == "weighted"
    expect = playwright_api.expect  # the panel shows the preset's hierarchy method
    expect(page.get_by_label("Hierarchy", exact=True).first).to_have_value("weighted")


def test_choosing_another_robot_switches_it(page, lab: LabClient) -> None:
    before = dark_pixels(page)
    choose(page, "Robot", "solo12")
    lab.wait_telemetry(lambda m: m["robot"] == "solo12", timeout=30.0)
    page.get_by_text("solo12", exact=True).first.wait_for()
    page.get_by_label("Robot", exact=True).first.wait_for()
    after = wait_dark_pixels(page, lambda n: 300 < n < 0.7 * before)
    assert 300 < after < 0.7 * before, (before, after)  # a smaller robot replaced ANYmal
