"""The Kim 2016 live plots in a real headless Chromium against a real `lab serve`: Bolt steps
under `biped_step`, and the CoM phase portraits and the internal-force chart draw (uPlot's own
y ranging gave the portraits a NaN scale: no points, no y axis; `lab/ui/plot_range.py`)."""

import time
from pathlib import Path

import pytest

from tests.helpers.browser import CHROMIUM, CHROMIUM_ARGS, LabServe

playwright_api = pytest.importorskip("playwright.sync_api")

pytestmark = pytest.mark.browser
VIEWPORT = {"width": 1400, "height": 800}
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


def _portraits_drawn(charts: list[dict]) -> bool:
    portraits = [c for c in charts if c["title"].startswith("CoM phase portrait")]
    return len(portraits) == 2 and all(min(c["counts"]) >= MIN_POINT_PX for c in portraits)


def test_stepping_bolts_phase_portraits_draw_the_path_and_the_prediction(tmp_path: Path) -> None:
    if not Path(CHROMIUM).exists():
        pytest.skip(f"no Chromium at {CHROMIUM} (./dev test installs Debian's chromium)")
    serve = LabServe(tmp_path / "serve.log", "--robot", "bolt")
    try:
        with serve.client() as lab:
            assert lab.command("gait", name="biped_step")["ok"]
            serve.wait_ui()
            with playwright_api.sync_playwright() as p:
                browser = p.chromium.launch(
                    executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS
                )
                page = browser.new_page(viewport=VIEWPORT)
                page.goto(serve.url)
                end = time.monotonic() + DRAW_TIMEOUT_MS / 1000
                charts = page.evaluate(READ_CHARTS)
                while not _portraits_drawn(charts) and time.monotonic() < end:
                    page.wait_for_timeout(500)
                    charts = page.evaluate(READ_CHARTS)
                browser.close()
            tel = lab.latest_telemetry()
    finally:
        serve.stop()
    assert tel is not None and not tel["fell"] and tel["stepping"]["steps"] >= 3, tel
    assert _portraits_drawn(charts), charts
    for chart in charts:  # every chart shown has a finite y range (NaN draws nothing)
        low, high = chart["y"]
        assert low is not None and high is not None and low < high, chart
    force = [c for c in charts if c["title"].startswith("Internal force")]
    assert len(force) == 1, charts
