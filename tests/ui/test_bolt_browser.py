"""Bolt in a real headless Chromium against a real `lab serve --robot bolt`, one server and one
page shared by the tests in file order: Bolt steps under `biped_step` picked in the Gait
dropdown and Kim 2016's live plots draw (uPlot's own y ranging gave the CoM phase portraits a NaN
scale: no points, no y axis; `lab/ui/plot_range.py`); then a Reset stands it on its default
stack, and the split wedges' set-up from the page holds it, across a Reset too; last, a push
from the page reaches the server (the robot and scene walk of test_ui_browser.py leaves Bolt
and split_wedges to this file)."""

import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from lab.client import LabClient
from lab.description import load_description
from lab.ui.push_controls import default_push_newtons
from tests.helpers.browser import (
    CHROMIUM,
    CHROMIUM_ARGS,
    LOAD_TIMEOUT_MS,
    PAGE_TIMEOUT_MS,
    UI_ACTION_TIMEOUT_S,
    LabServe,
    Pushes,
    choose,
    console_errors,
    new_context,
    press,
    slider_box,
    ui_alive,
    wait_drawn,
)

playwright_api = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.browser
DRAW_TIMEOUT_MS = 120_000  # the page's first draw took up to 60 s at load 20 (test_ui_browser)
MIN_POINT_PX = 30  # canvas pixels of a series' colour in a chart's plotting area

# Per registered uPlot chart (viser's testpoint): its title, y scale and how many pixels of its
# plotting area are near each of the portraits' colours (path red, prediction blue).
READ_CHARTS = """() => {
  const charts = Object.values(window.__viserTestpoints?.uplots ?? {}).map(e => e.chart);
  const near = (p, i, c) => Math.abs(p[i] - c[0]) + Math.abs(p[i + 1] - c[1])
    + Math.abs(p[i + 2] - c[2]) < 90 && p[i + 3] > 128;
  return charts.map(u => {
    const b = u.bbox, counts = [0, 0];
    if (b.width > 0 && b.height > 0) {
      const p = u.ctx.getImageData(b.left, b.top, b.width, b.height).data;
      for (let i = 0; i < p.length; i += 4) {
        if (near(p, i, [214, 39, 40])) counts[0]++;
        else if (near(p, i, [31, 119, 180])) counts[1]++;
      }
    }
    return {title: u.root.querySelector(".u-title")?.textContent ?? "",
            y: [u.scales.y?.min ?? null, u.scales.y?.max ?? null], counts};
  });
}"""


@pytest.fixture(scope="module")
def serve(tmp_path_factory: pytest.TempPathFactory) -> Iterator[LabServe]:
    srv = LabServe(tmp_path_factory.mktemp("bolt") / "serve.log", "--robot", "bolt")
    yield srv
    srv.stop()


@pytest.fixture(scope="module")
def lab(serve: LabServe) -> Iterator[LabClient]:
    client = serve.client()
    yield client
    client.close()


@pytest.fixture(scope="module")
def page(serve: LabServe, lab: LabClient):
    if not Path(CHROMIUM).exists():
        pytest.skip(f"no Chromium at {CHROMIUM} (./dev test installs Debian's chromium)")
    with playwright_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
        pg = new_context(browser).new_page()
        pg.set_default_timeout(PAGE_TIMEOUT_MS)
        pg.console_errors = console_errors(pg)
        frames: list[float] = []
        pg.on("websocket", lambda ws: ws.on("framereceived", lambda _: frames.append(0.0)))
        pg.ws_frames = frames
        serve.wait_ui()
        pg.goto(serve.url)
        pg.get_by_text("You hold control").wait_for(timeout=LOAD_TIMEOUT_MS)  # the first load
        wait_drawn(pg, "bolt")
        yield pg
        browser.close()


def _portraits_drawn(charts: list[dict]) -> bool:
    portraits = [c for c in charts if c["title"].startswith("CoM phase portrait")]
    return len(portraits) == 2 and all(min(c["counts"]) >= MIN_POINT_PX for c in portraits)


def test_stepping_bolts_phase_portraits_draw_the_path_and_the_prediction(page, lab) -> None:
    """`biped_step` from the Gait dropdown: both phase portraits show at least MIN_POINT_PX
    pixels of the path's red and of the prediction's blue, every chart shown has a finite y
    range, and Bolt steps without falling."""
    choose(page, "Gait", "biped_step")  # brings kim_stepping, which has no CoM task
    lab.wait_telemetry(lambda m: m["gait"] == "biped_step", timeout=UI_ACTION_TIMEOUT_S)
    end = time.monotonic() + DRAW_TIMEOUT_MS / 1000
    charts = page.evaluate(READ_CHARTS)
    while not _portraits_drawn(charts) and time.monotonic() < end:
        page.wait_for_timeout(500)
        charts = page.evaluate(READ_CHARTS)
    # three steps taken (or a fall): the charts may fill before the third step on a quick page
    tel = lab.wait_telemetry(
        lambda m: m["fell"] or m["stepping"]["steps"] >= 3, timeout=UI_ACTION_TIMEOUT_S
    )
    assert not tel["fell"] and tel["stepping"]["steps"] >= 3, tel
    assert _portraits_drawn(charts), charts
    for chart in charts:  # every chart shown has a finite y range (NaN draws nothing)
        low, high = chart["y"]
        assert low is not None and high is not None and low < high, chart
    force = [c for c in charts if c["title"].startswith("Internal force")]
    assert len(force) == 1, charts


def reset_from_page(page, lab: LabClient) -> dict:
    """Press Reset in the page; the first telemetry message after it: the first whose clock is
    behind the message before it (read in order). A message with a small clock read as soon as
    Reset was pressed may still be of the run before (on 2026-12-05 one such, the robot fallen
    before the Reset, was taken for a fall after it)."""
    last = lab.wait_telemetry(timeout=60.0)["t"]

    def rewound(message: dict) -> bool:
        nonlocal last
        back, last = message["t"] < last, message["t"]
        return back

    press(page, "Reset")
    return lab.wait_telemetry(rewound, timeout=60.0, since_last_read=True)


def test_bolt_on_the_split_wedges_from_the_page_holds_across_a_reset(page, lab) -> None:
    """Reset after stepping (the test above) stands, on the default stack. Picking Kim's split
    wedges asks first about the set-up they were made for; *Use it* switches with WBOSC and the
    internal force (0.51 m g, K_F 1) from the scene's first tick, shows their controls and
    chart, and Bolt holds on the wedges from the switch and across a Reset. (Asked after the
    switch, Bolt fell on the wedges at 0.3-0.5 s under its default stack, before the answer.)"""
    default = [list(level) for level in load_description("bolt").stack]
    assert lab.command("info")["gait"] == "biped_step"  # stepping since the test above
    press(page, "Reset")  # back to standing on a stack that stands: Bolt fell at 1.4 s
    stand = lab.wait_telemetry(lambda m: m["gait"] == "stand", timeout=60.0)
    assert stand["stack"] == default, stand["stack"]
    stood = lab.wait_telemetry(lambda m: m["t"] > 2.5 or m["fell"], timeout=120.0)
    assert not stood["fell"]
    choose(page, "Scene", "split_wedges")
    page.get_by_text("Scene split_wedges was made for this set-up").first.wait_for()
    assert lab.command("info")["scene"] == "flat"  # nothing switched before the answer
    press(page, "Use it")
    mass = lab.command("info", timeout=60.0)["mass"]
    first = lab.wait_telemetry(lambda m: m["scene"] == "split_wedges", timeout=60.0)
    assert first["hierarchy"]["method"] == "wbosc", first["hierarchy"]
    assert first["internal_force"]["reference"] == pytest.approx(0.51 * mass * 9.81, 0.01)
    held = lab.wait_telemetry(lambda m: m["t"] > 2.0 or m["fell"], timeout=120.0)
    assert not held["fell"], held["t"]  # on the wedges from the switch on
    page.get_by_text("Internal force (Kim 2016)").first.wait_for()
    page.get_by_text("Internal force between the feet").first.wait_for()  # its chart
    wait_drawn(page, "bolt")  # on the wedges, the dialog closed
    back = reset_from_page(page, lab)
    assert not back["fell"] and back["hierarchy"]["method"] == "wbosc"  # Reset keeps the set-up
    after = lab.wait_telemetry(lambda m: m["t"] > 2.0 or m["fell"], timeout=120.0)
    assert not after["fell"], after["t"]
    assert not page.console_errors, page.console_errors


def test_bolts_page_says_how_it_stands_and_its_default_push_reaches_the_server(
    page, lab: LabClient, serve: LabServe
) -> None:
    """The page says how Bolt stands, offers a push of its share of Bolt's weight, and the push
    sent from the page arrives; the UI still serves, streams and logged no UI error, and nothing
    on this page raised: no console error, no traceback from `lab serve`."""
    page.get_by_text("Bolt stands on its two point feet").first.wait_for()
    box = slider_box(page, "Magnitude [N]")
    wanted = str(int(default_push_newtons(lab.command("info")["mass"])))
    playwright_api.expect(box).to_have_value(wanted, timeout=PAGE_TIMEOUT_MS)
    pushes = Pushes(lab)
    press(page, "forward")
    pushes.wait(float(box.input_value()))
    ui_alive(page, serve)
    assert not page.console_errors, page.console_errors[:5]
    output = serve.log.read_text(errors="replace")
    assert "Traceback" not in output, output[-4000:]
