"""What the page's status line says a user gets (issue 26): `lab serve` with its page in Debian's
headless Chromium; in the page, Bolt with its walking gait (`biped_step`), then ANYmal and Talos
each under `nullspace`; after a settling time the status line's text, beside the server's own
figures over the same seconds.

    .venv/bin/python benchmarks/bench_status_line.py [--settle 20] [--reads 3] [--json]

A benchmark, not a test: the figures are the machine's as much as the lab's, so say the load
(`uptime`, printed at the start and the end). The server's own figures come from telemetry as a
second client receives it: the sim time and the loop's tick and on-time counters (telemetry's
`loop`), differenced over the status line's window (lab/ui/status.py WINDOW_S) of the loop's own
clock (`loop.clock_s`), so that the page's "RTF … last 5 s" and "on-time … last 5 s" can be held
against them (the two windows end a few tens of ms apart: the page shows the newest message it
drew).
"""

import argparse
import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from lab.ui.status import WINDOW_S
from tests.helpers.browser import (
    CHROMIUM,
    CHROMIUM_ARGS,
    PAGE_TIMEOUT_MS,
    VIEWPORT,
    LabServe,
    choose,
    require_chromium,
    wait_drawn,
)

# (robot, gait picked in the page or None, hierarchy method picked or None)
SITUATIONS = (
    ("bolt", "biped_step", None),
    ("anymal", None, "nullspace"),
    ("talos", None, "nullspace"),
)


class ServerFigures:
    """Telemetry as a second client receives it: (the loop's clock s, sim t, loop ticks, ticks
    on time, overruns, robot, gait, method) per message."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.samples: list[tuple[float, float, int, float, int, str, str, str]] = []

    def add(self, tel: dict) -> None:
        loop = tel.get("loop") or {}
        ticks = int(loop.get("ticks", 0))
        clock = loop.get("clock_s")  # the loop's clock when it built the message
        sample = (
            time.monotonic() if clock is None else clock,
            float(tel["t"]),
            ticks,
            loop.get("on_time_fraction", 1.0) * ticks,
            int(loop.get("overruns", 0)),
            tel["robot"],
            tel["gait"],
            tel["ran"]["method"],
        )
        with self._lock:
            self.samples.append(sample)

    def window(self, seconds: float = WINDOW_S) -> dict:
        """The server's figures over the last `seconds`: real-time factor (sim s over wall s),
        the loop's ticks per wall second, on-time fraction and overruns."""
        with self._lock:
            last = self.samples[-1]
            first = next(s for s in self.samples if s[0] >= last[0] - seconds)
        wall, sim, ticks = last[0] - first[0], last[1] - first[1], last[2] - first[2]
        return {
            "seconds": round(wall, 2),
            "rtf": round(sim / wall, 3) if wall > 0 else None,
            "ticks_per_s": round(ticks / wall, 1) if wall > 0 else None,
            "on_time": round((last[3] - first[3]) / ticks, 4) if ticks > 0 else None,
            "overruns": last[4] - first[4],
            "robot": last[5],
            "gait": last[6],
            "method": last[7],
        }


def status_text(page) -> str:
    """The status line's three lines as the page shows them."""
    return page.locator("p", has_text="RTF").first.inner_text()


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv: list[str] | None = None) -> int:
    from playwright.sync_api import sync_playwright

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--settle", type=float, default=20.0, help="s after each pick")
    parser.add_argument("--reads", type=int, default=3, help="status reads, 2 s apart")
    parser.add_argument(
        "--robots",
        nargs="+",
        choices=[robot for robot, _, _ in SITUATIONS],
        default=[robot for robot, _, _ in SITUATIONS],
        help="these situations only; lab serve starts with the first one's robot",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object at the end")
    args = parser.parse_args(argv)
    require_chromium("bench_status_line.py")
    situations = [s for s in SITUATIONS if s[0] in args.robots]
    results = {"load_start": load(), "situations": []}
    print(f"load average at start: {results['load_start']}", flush=True)
    log = Path(tempfile.mkdtemp(prefix="lab-status-")) / "serve.log"
    server = LabServe(log, "--robot", situations[0][0])
    figures = ServerFigures()
    client = None
    try:
        client = server.client()
        client.subscribe_telemetry(figures.add)
        server.wait_ui()
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport=VIEWPORT)
            # a mouse click waits for a rendered frame: at load 44 a software-rendered page
            # took more than a minute for one (the Robot dropdown's click timed out)
            page.set_default_timeout(4 * PAGE_TIMEOUT_MS)
            page.goto(server.url)
            page.get_by_text("You hold control").wait_for()
            wait_drawn(page, situations[0][0])
            for robot, gait, method in situations:
                if client.command("info")["robot"] != robot:
                    choose(page, "Robot", robot)
                    client.wait_telemetry(lambda m, r=robot: m["robot"] == r, timeout=120.0)
                    wait_drawn(page, robot)
                if gait is not None:
                    choose(page, "Gait", gait)
                    client.wait_telemetry(lambda m, g=gait: m["gait"] == g, timeout=60.0)
                if method is not None:
                    choose(page, "Hierarchy", method)
                    client.wait_telemetry(lambda m, h=method: m["ran"]["method"] == h, timeout=60.0)
                page.wait_for_timeout(args.settle * 1000)
                reads = []
                for _ in range(args.reads):
                    reads.append(
                        {"status": status_text(page), "server": figures.window(), "load": load()}
                    )
                    page.wait_for_timeout(2000)
                situation = {"robot": robot, "gait": gait, "method": method, "reads": reads}
                results["situations"].append(situation)
                print(f"\n== {robot} {gait or ''} {method or ''}".rstrip(), flush=True)
                for read in reads:
                    print(read["status"].replace("\n", "\n   "))
                    print(f"   server, last {WINDOW_S:g} s: {read['server']}; load {read['load']}")
            browser.close()
    finally:
        if client is not None:  # its Zenoh session's threads would keep the process alive
            client.close()
        server.stop()
    results["load_end"] = load()
    print(f"\nload average at end: {results['load_end']} (lab serve's log: {log})")
    if args.json:
        print(json.dumps(results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
