"""The browser files' shared lab, one per test module: `lab serve --robot anymal` on free ports
(with a record directory), a headless Chromium, a page holding the lab's control, and the
pushes the server reports. Module scope: each file that uses them starts its own, so that
pytest-xdist's two workers run two such files at once (tests/ui/test_ui_browser.py and the
robot and scene walk, tests/ui/test_ui_walk.py)."""

import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from lab.client import LabClient
from tests.helpers.browser import (
    CHROMIUM,
    CHROMIUM_ARGS,
    PAGE_TIMEOUT_MS,
    VIEWPORT,
    LabServe,
    Pushes,
    console_errors,
)


@pytest.fixture(scope="module")
def serve(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LabServe]:
    tmp = tmp_path_factory.mktemp("ui")
    srv = LabServe(tmp / "serve.log", "--robot", "anymal", "--record-dir", str(tmp / "rec"))
    srv.record_dir = tmp / "rec"
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
    playwright_api = pytest.importorskip("playwright.sync_api")
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
    pg.console_errors = console_errors(pg)
    serve.wait_ui()
    pg.goto(serve.url)
    pg.get_by_text("You hold control").wait_for()
    pg.ws_frames = frames
    yield pg
    context.close()


@pytest.fixture(scope="module")
def pushes(lab: LabClient) -> Pushes:
    return Pushes(lab)
