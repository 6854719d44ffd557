"""Helpers for the browser tests: a `lab serve` process with its UI on free loopback ports,
Debian's headless Chromium driven by playwright (never a downloaded browser), and what a test
does in the page (press a button, pick from a dropdown, wait until the robot is drawn).

playwright is imported inside the page helpers: a test module skips itself when it is missing
(`pytest.importorskip`), after importing this one."""

import io
import math
import shutil
import subprocess
import sys
import threading
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from lab.client import LabClient
from tests.helpers.ports import free_port

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
STARTUP_TIMEOUT_S = 60.0
# Never SCHED_FIFO for the server under test: a FIFO 1 kHz loop can starve the UI process and
# Chromium on a 2-core machine (later LabServe args override this).
SERVE_OPTIONS = ("--sched", "other")


def serves_http(port: int) -> bool:
    """Whether an HTTP server answers a GET on `port` of the loopback. (A bare TCP connection
    closed unanswered makes viser's websocket server print a handshake traceback, which the
    browser tests count as a fault.)"""
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=2.0):
            return True
    except OSError:
        return False


class LabServe:
    """`lab serve` (sim process + UI process) on free ports, output to `log`."""

    def __init__(self, log: Path, *args: str, port: int | None = None) -> None:
        self.port = free_port() if port is None else port
        self.ui_port = free_port()
        self.endpoint = f"tcp/127.0.0.1:{self.port}"
        self.url = f"http://127.0.0.1:{self.ui_port}"
        self.log = log
        cmd = [sys.executable, "-m", "lab.runtime.serve", "--port", str(self.port)]
        cmd += ["--ui-port", str(self.ui_port), *SERVE_OPTIONS, *args]
        with log.open("wb") as out:
            self.process = subprocess.Popen(cmd, stdout=out, stderr=subprocess.STDOUT)

    def output(self) -> str:
        return self.log.read_text(errors="replace")[-4000:]

    def client(self) -> LabClient:
        end = time.monotonic() + STARTUP_TIMEOUT_S
        while time.monotonic() < end:
            assert self.process.poll() is None, f"lab serve exited:\n{self.output()}"
            try:
                client = LabClient(self.endpoint, connect_timeout=1.0)
            except Exception:  # not listening yet
                time.sleep(0.3)
                continue
            if client.command("info").get("ok"):
                return client
            client.close()
            time.sleep(0.3)
        raise TimeoutError(
            f"lab serve did not answer within {STARTUP_TIMEOUT_S} s:\n{self.output()}"
        )

    def wait_ui(self) -> None:
        """Wait until the UI process serves HTTP."""
        end = time.monotonic() + STARTUP_TIMEOUT_S
        while time.monotonic() < end:
            assert self.process.poll() is None, f"lab serve exited:\n{self.output()}"
            if serves_http(self.ui_port):
                return
            time.sleep(0.3)
        raise TimeoutError(f"the UI did not serve HTTP within {STARTUP_TIMEOUT_S} s")

    def stop(self) -> None:
        self.process.terminate()
        try:
            self.process.wait(10.0)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()


VIEWPORT = {"width": 1400, "height": 800}  # plots | 3-D view | controls
# Frames per second a test page may draw. Its 3-D view renders in software (SwiftShader) on the
# same 2 cores as the lab, the other worker's tests and the sim loop; at the browser's own rate it
# draws as often as the processor lets it (a watched ANYmal page at load 7-9: 4.5-9 frames a
# second and 0.70-0.79 processor s/s for Chromium, against 0.43 at 3 frames a second; round 16,
# docs/reliability.md). No test reads the page's frame rate (the status line's "view NN fps" is
# the UI process's drawing rate, and the liveness check counts websocket frames, which the UI
# process sends whatever the page draws: 22-26 a second either way). Viser applies scene
# messages once per drawn frame, so what a test waits for in the page (text, pixels, a chart's
# data) shows up to 1/PAGE_FPS s later; every such wait polls for tens of seconds.
PAGE_FPS = 3
# An init script (the page's own world: playwright's injected scripts keep the browser's
# requestAnimationFrame) that runs every animation-frame callback at most PAGE_FPS times a second:
# the callbacks wait together and run in one real frame.
CAP_FRAME_RATE = f"""(() => {{
  const period = 1000 / {PAGE_FPS}, raf = window.requestAnimationFrame.bind(window);
  let queue = new Map(), nextId = 1, last = -Infinity, scheduled = false;
  const flush = (t) => {{
    scheduled = false;
    last = t;
    const due = queue;
    queue = new Map();
    for (const callback of due.values()) callback(t);
  }};
  window.requestAnimationFrame = (callback) => {{
    const id = nextId++;
    queue.set(id, callback);
    if (!scheduled) {{
      scheduled = true;
      setTimeout(() => raf(flush), Math.max(0, last + period - performance.now()));
    }}
    return id;
  }};
  window.cancelAnimationFrame = (id) => {{ queue.delete(id); }};
}})();"""
PAGE_TIMEOUT_MS = 60_000
# s: from a click in the page to its effect in telemetry or `info`. A second or less when idle;
# generous because on a loaded 2-core machine the browser and the UI process share what is left.
UI_ACTION_TIMEOUT_S = 30.0
# ms: a robot's view is built (status line "Loading …") in a second or two from the mesh cache,
# but converting the meshes on a cold cache took ANYmal 40 s on a busy 2-core machine.
LOAD_TIMEOUT_MS = 180_000
OPEN_DROPDOWN_TRIES = 3
OPEN_DROPDOWN_WAIT_MS = 20_000


def require_chromium(program: str) -> None:
    """Exit with one clear line when Debian's Chromium is missing (a benchmark that drives the
    page: playwright's own error comes only after the lab has started, and is about a path)."""
    if not Path(CHROMIUM).exists():
        raise SystemExit(
            f"{program}: no Chromium at {CHROMIUM}; ./dev test installs Debian's chromium "
            "(or: apt-get install chromium)"
        )


@pytest.fixture(scope="module")
def browser() -> Iterator[object]:
    """Debian's headless Chromium, one per test module (tests/conftest.py imports this)."""
    if not Path(CHROMIUM).exists():
        pytest.skip(f"no Chromium at {CHROMIUM} (./dev test installs Debian's chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        yield b
        b.close()


def new_context(browser):
    """A browser context of VIEWPORT size whose pages draw at most PAGE_FPS frames a second."""
    context = browser.new_context(viewport=VIEWPORT)
    context.add_init_script(CAP_FRAME_RATE)
    return context


def dark_pixels(pg) -> int:
    """Pixels of the 3-D view (its canvas, between the plots and the control panel) darker than
    the floor and grid lines: the robot's meshes and their shadows."""
    from PIL import Image

    box = pg.locator("canvas").first.bounding_box()  # viser's 3-D canvas comes first
    shot = np.asarray(Image.open(io.BytesIO(pg.screenshot())).convert("L"))
    view = shot[150:, int(box["x"]) : int(box["x"] + box["width"])]
    return int((view < 90).sum())


def wait_dark_pixels(pg, predicate, timeout: float = 30.0) -> int:
    """Poll `dark_pixels` until `predicate` holds (viser fades new meshes in) or time is up."""
    end = time.monotonic() + timeout
    n = dark_pixels(pg)
    while not predicate(n) and time.monotonic() < end:
        pg.wait_for_timeout(500)
        n = dark_pixels(pg)
    return n


def console_errors(pg) -> list[str]:
    """The page's console errors and uncaught exceptions, collected from now on."""
    errors: list[str] = []
    pg.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    pg.on("pageerror", lambda e: errors.append(f"uncaught: {e}"))
    return errors


def press(pg, button: str) -> None:
    """Click a panel button by its DOM click event: a mouse click waits for a rendered frame,
    which a software-rendered page on a loaded machine may not produce for a minute."""
    pg.get_by_role("button", name=button, exact=True).dispatch_event("click")


def open_dropdown(pg, label: str, wanted) -> None:
    """Open dropdown `label` until locator `wanted` (one of its options) shows. A click that
    lands while the panel re-renders leaves the dropdown closed (seen in a fresh-clone run and
    under a CPU hog: the options never appeared), so the dropdown is clicked again, at most
    OPEN_DROPDOWN_TRIES times. (A DOM click event does not open viser's dropdowns: it takes a
    mouse click.)"""
    from playwright.sync_api import TimeoutError as PlaywrightTimeout

    for _ in range(OPEN_DROPDOWN_TRIES - 1):
        pg.get_by_label(label, exact=True).first.click(no_wait_after=True)
        try:
            wanted.wait_for(timeout=OPEN_DROPDOWN_WAIT_MS)
            return
        except PlaywrightTimeout:
            continue
    pg.get_by_label(label, exact=True).first.click(no_wait_after=True)
    wanted.wait_for()


def choose(pg, label: str, option: str) -> None:
    """Open dropdown `label` and pick `option`."""
    wanted = pg.get_by_role("option", name=option, exact=True)
    open_dropdown(pg, label, wanted)
    wanted.click(no_wait_after=True)


def event_log(pg) -> str:
    """The text of the page's event log."""
    return pg.get_by_text("Events, newest first").first.locator("xpath=..").inner_text()


def wait_drawn(page, robot: str) -> None:
    """The status line names `robot` (from live telemetry, no longer loading) and the view shows
    a robot."""
    from playwright.sync_api import expect

    status = page.get_by_text(f"{robot} on", exact=False).first
    expect(status).to_be_visible(timeout=PAGE_TIMEOUT_MS)
    expect(page.get_by_text("Loading")).to_have_count(0, timeout=LOAD_TIMEOUT_MS)
    assert wait_dark_pixels(page, lambda n: n > 300, timeout=60.0) > 300


def slider_box(pg, label: str):
    """The number box beside a viser slider (the slider's label points at the slider)."""
    slider = pg.locator("label", has_text=label).first.get_attribute("for")
    return pg.locator(f"[id='{slider}']").locator("xpath=..").locator("input:not([type=hidden])")


class Pushes:
    """Every push the server reports in telemetry, as (|force| N, longest remaining s), from
    the moment the subscription has received its first message: a subscriber just declared
    receives nothing until the server knows of it, and a push pressed in the page before then
    (the page's link to the lab is another than this client's) would be missed."""

    def __init__(self, lab: LabClient, timeout: float = UI_ACTION_TIMEOUT_S) -> None:
        self.seen: dict[float, float] = {}
        self.listening = threading.Event()
        lab.subscribe_telemetry(self._record)
        if not self.listening.wait(timeout):
            raise TimeoutError(f"no telemetry reached a new subscriber within {timeout} s")

    def _record(self, tel: dict) -> None:
        self.listening.set()
        for push in tel["pushes"]:
            norm = round(math.hypot(*push["force"]), 6)
            self.seen[norm] = max(self.seen.get(norm, 0.0), push["remaining"])

    def wait(self, norm: float, timeout: float = 20.0) -> float:
        """The longest remaining time seen of a push of `norm` N."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if round(norm, 6) in self.seen:
                time.sleep(0.3)  # later messages of the same push
                return self.seen[round(norm, 6)]
            time.sleep(0.05)
        raise AssertionError(f"no push of {norm} N reached the server; seen {self.seen}")


def ui_alive(page, serve: LabServe) -> None:
    """The UI process serves HTTP, streams to the page (a new frame arrives within
    UI_ACTION_TIMEOUT_S: polled, not a fixed wait), and logged no error of its own."""
    assert serves_http(serve.ui_port)
    n0 = len(page.ws_frames)
    end = time.monotonic() + UI_ACTION_TIMEOUT_S
    while len(page.ws_frames) <= n0 and time.monotonic() < end:
        page.wait_for_timeout(100)  # lets playwright dispatch the websocket events
    assert len(page.ws_frames) > n0, "the page gets no more updates"
    assert "UI error" not in event_log(page), event_log(page)
