"""Pages in a real headless Chromium against processes of their own, each started by its test:
a remote UI process beside a headless sim that is killed and started again, a page opened
before its lab, and `lab replay --serve`'s page.

Apart from test_ui_browser.py so that they neither wait for its shared page nor run beside its
server, UI process and page (a module's fixtures live until its last test): they share only
the browser (tests/helpers/browser.py), and the other pytest-xdist worker can take them.
"""

import subprocess
import sys
import time

import numpy as np
import pytest

from tests.helpers.browser import (
    LOAD_TIMEOUT_MS,
    PAGE_TIMEOUT_MS,
    LabServe,
    console_errors,
    event_log,
    new_context,
    serves_http,
    wait_dark_pixels,
)
from tests.helpers.ports import free_port

playwright_api = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.browser


def test_a_page_whose_sim_process_dies_says_disconnected_and_recovers(browser, tmp_path) -> None:
    """A remote UI process (`python -m lab.ui --connect`) beside a headless sim: SIGKILL to the
    sim makes the page say "Disconnected" (status line and event log) instead of showing a
    frozen robot as if it ran; a new sim on the same endpoint is found again by itself."""
    sim = LabServe(tmp_path / "sim.log", "--headless")
    ui_port = free_port()
    with (tmp_path / "ui.log").open("wb") as out:
        ui = subprocess.Popen(
            [sys.executable, "-m", "lab.ui", "--port", str(ui_port), "--connect", sim.endpoint],
            stdout=out,
            stderr=subprocess.STDOUT,
        )
    again = None
    context = new_context(browser)
    try:
        sim.client().close()
        pg = context.new_page()
        pg.set_default_timeout(PAGE_TIMEOUT_MS)
        end = time.monotonic() + LOAD_TIMEOUT_MS / 1000
        while time.monotonic() < end and not serves_http(ui_port):
            time.sleep(0.3)
        pg.goto(f"http://127.0.0.1:{ui_port}")
        running = pg.get_by_text("anymal on", exact=False).first
        playwright_api.expect(running).to_be_visible(timeout=LOAD_TIMEOUT_MS)
        sim.process.kill()
        sim.process.wait()
        lost = pg.get_by_text("Disconnected since").first
        playwright_api.expect(lost).to_be_visible(timeout=PAGE_TIMEOUT_MS)
        assert "is not reachable" in event_log(pg)
        again = LabServe(tmp_path / "sim2.log", "--headless", port=sim.port)
        again.client().close()
        log = pg.get_by_text("Events, newest first").first.locator("xpath=..")
        back = "the lab server is back"
        playwright_api.expect(log).to_contain_text(back, timeout=PAGE_TIMEOUT_MS)
        gone = pg.get_by_text("Disconnected since")
        playwright_api.expect(gone).to_have_count(0, timeout=PAGE_TIMEOUT_MS)
        playwright_api.expect(running).to_be_visible(timeout=PAGE_TIMEOUT_MS)
        assert ui.poll() is None, "the UI process ended"
    finally:
        context.close()
        ui.terminate()
        ui.wait()
        for process in (sim, again):
            if process is not None:
                process.stop()


# Per registered uPlot chart (viser's testpoint): its title, whether it shows, its x data and x
# scale, where its first series' first finite sample is, and a sum of that series (it changes).
READ_TIME_AXES = """() => Object.values(window.__viserTestpoints?.uplots ?? {}).map(e => {
  const u = e.chart, xs = u.data[0], ys = u.data[1] ?? [];
  const first = ys.findIndex(v => Number.isFinite(v));
  return {title: u.root.querySelector('.u-title')?.textContent ?? '', n: xs.length,
          visible: u.root.offsetParent !== null,
          x0: xs[0] ?? null, x1: xs[xs.length - 1] ?? null,
          first: first >= 0 ? xs[first] : null,
          sum: ys.reduce((a, v) => Number.isFinite(v) ? a + v : a, 0),
          min: u.scales.x?.min ?? null, max: u.scales.x?.max ?? null};
})"""
PLOT_WINDOW_S = 10.0  # the page's default window
PLOT_LAG_S = 3.0  # s of sim time a drawn chart may trail the newest telemetry on a loaded machine


def _following(charts: list[dict], before: list[dict], t_now: float) -> list[str]:
    """Why the time charts (read now and, `before`, a moment earlier) do not show the last
    window's samples up to the newest, `t_now` s of sim time after a reset; [] when they do.
    Their time axis reads seconds before the newest sample: [-window, 0]."""
    timed = [c for c in charts if c["visible"] and not c["title"].startswith("CoM phase")]
    if len(timed) < 5:
        return [f"only {len(timed)} time charts drawn: {charts}"]
    earlier = {c["title"]: c for c in before}
    window = PLOT_WINDOW_S
    shown = min(PLOT_WINDOW_S, t_now) - PLOT_LAG_S  # s of samples each chart must show at least
    wrong = []
    for c in timed:
        if c["n"] < 10 or c["first"] is None:
            wrong.append(f"{c['title']}: {c['n']} points, first sample {c['first']}")
        elif c["x1"] != 0 or c["x0"] < -PLOT_WINDOW_S or [c["min"], c["max"]] != [-window, 0]:
            wrong.append(f"{c['title']}: data {c['x0']}..{c['x1']} s, axis {c['min']}..{c['max']}")
        elif c["first"] > -shown:
            wrong.append(f"{c['title']}: samples from {c['first']:.2f} s only, at t {t_now:.2f}")
        elif earlier.get(c["title"], {}).get("sum") == c["sum"]:
            wrong.append(f"{c['title']}: not redrawn")
    return wrong


def test_plots_opened_before_the_lab_follow_the_data_across_a_switch_and_a_reset(
    browser, tmp_path
) -> None:
    """A page open before the sim process starts; the lab switches robot, then resets: every
    time chart then holds the last window's samples (from the reset on) and its time axis spans
    exactly them (the axis stuck on a 1 s slice 35 s behind, or at -10,530 s after a reset).
    No console error and no UI traceback on the way."""
    port, ui_port = free_port(), free_port()
    with (tmp_path / "ui.log").open("wb") as out:
        ui = subprocess.Popen(
            [sys.executable, "-m", "lab.ui", "--port", str(ui_port), "--connect",
             f"tcp/127.0.0.1:{port}"],
            stdout=out, stderr=subprocess.STDOUT,
        )  # fmt: skip
    context = new_context(browser)
    sim = None
    try:
        pg = context.new_page()
        pg.set_default_timeout(PAGE_TIMEOUT_MS)
        errors = console_errors(pg)
        end = time.monotonic() + LOAD_TIMEOUT_MS / 1000
        while time.monotonic() < end and not serves_http(ui_port):
            time.sleep(0.3)  # (an HTTP probe: a bare TCP one makes a handshake traceback)
        pg.goto(f"http://127.0.0.1:{ui_port}")
        pg.get_by_text("WBC lab").first.wait_for(timeout=LOAD_TIMEOUT_MS)  # open, no lab yet
        sim = LabServe(tmp_path / "sim.log", "--headless", port=port)
        with sim.client() as lab:
            lab.wait_telemetry(lambda m: m["t"] > 2.0, timeout=60.0)
            assert lab.command("robot", name="solo12")["ok"]
            lab.wait_telemetry(lambda m: m["robot"] == "solo12" and m["t"] > 2.0, timeout=60.0)
            assert lab.command("reset")["ok"]
            lab.wait_telemetry(lambda m: m["t"] < 1.0, timeout=60.0, since_last_read=True)
            lab.wait_telemetry(lambda m: m["t"] > 4.0, timeout=60.0)
            end = time.monotonic() + 60.0
            wrong, before = ["not read"], pg.evaluate(READ_TIME_AXES)
            while wrong and time.monotonic() < end:
                pg.wait_for_timeout(1000)
                t_now, charts = lab.latest_telemetry()["t"], pg.evaluate(READ_TIME_AXES)
                wrong, before = _following(charts, before, t_now), charts
        assert not wrong, wrong
        assert not errors, errors
    finally:
        context.close()
        ui.terminate()
        ui.wait()
        if sim is not None:
            sim.stop()
    log = (tmp_path / "ui.log").read_text(errors="replace")
    assert "Traceback" not in log, log[-3000:]


def floor_fraction(pg) -> float:
    """The share of the 3-D view's pixels that are terrain or grid grey (neither the white
    background nor the robot's dark meshes)."""
    import io

    from PIL import Image

    box = pg.locator("canvas").first.bounding_box()
    shot = np.asarray(Image.open(io.BytesIO(pg.screenshot())).convert("L"))
    view = shot[150:, int(box["x"]) : int(box["x"] + box["width"])]
    return float(((view > 150) & (view < 249)).mean())


def test_lab_replay_serve_starts_the_page_with_floor_timeline_and_controls_greyed(
    browser, tmp_path
) -> None:
    """`lab replay FILE --serve` starts the page as `lab serve` does: the recorded robot on its
    floor (drawn although the recording ended before the page opened), the timeline at the top,
    and the controls that cannot act on a recording greyed out, with the reason."""
    record = tmp_path / "stand.mcap"
    run = [sys.executable, "-m", "lab", "run", "scenarios/anymal_stand_cascade.toml"]
    subprocess.run([*run, "--duration", "1", "--record", str(record)], check=True, timeout=300)
    port, ui_port = free_port(), free_port()
    with (tmp_path / "replay.log").open("wb") as out:
        replay = subprocess.Popen(
            [sys.executable, "-m", "lab", "replay", str(record), "--serve", "--port", str(port),
             "--ui-port", str(ui_port)],
            stdout=out, stderr=subprocess.STDOUT,
        )  # fmt: skip
    context = new_context(browser)
    try:
        end = time.monotonic() + LOAD_TIMEOUT_MS / 1000
        while time.monotonic() < end and not serves_http(ui_port):
            assert replay.poll() is None, (tmp_path / "replay.log").read_text()
            time.sleep(0.3)
        pg = context.new_page()
        pg.set_default_timeout(PAGE_TIMEOUT_MS)
        errors = console_errors(pg)
        pg.goto(f"http://127.0.0.1:{ui_port}")
        pg.get_by_text("A recording").first.wait_for(timeout=LOAD_TIMEOUT_MS)
        pg.get_by_text("Timeline [s]").first.wait_for()  # in the Replay folder, expanded
        assert pg.get_by_label("Gait", exact=True).first.is_disabled()
        assert pg.get_by_label("Robot", exact=True).first.is_disabled()
        assert pg.get_by_role("button", name="forward", exact=True).count() == 0
        gait = pg.get_by_label("Gait", exact=True).first.input_value()
        assert gait == "stand" and "anymal" in pg.get_by_text("anymal on").first.inner_text()
        shown = wait_dark_pixels(pg, lambda n: n > 300, timeout=LOAD_TIMEOUT_MS / 1000)
        assert shown > 300  # the robot
        end = time.monotonic() + 60.0
        while floor_fraction(pg) < 0.3 and time.monotonic() < end:
            pg.wait_for_timeout(500)
        assert floor_fraction(pg) >= 0.3, "no floor drawn"
        assert not errors, errors
    finally:
        context.close()
        replay.terminate()
        replay.wait()
