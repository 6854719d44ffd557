"""Load benchmark (not a test, not in CI): `lab serve` with its UI, N browser pages open at once
and M extra telemetry subscribers; reports the sim loop's on-time fraction over the window, each
page's frame rate (requestAnimationFrame callbacks per second in headless Chromium) and each
subscriber's telemetry rate.

    .venv/bin/python benchmarks/bench_load.py [--pages 10] [--subscribers 5] [--duration 30]

Uses Debian's Chromium through playwright, as the browser tests do (tests/browser.py).
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from browser import CHROMIUM, CHROMIUM_ARGS, LabServe

from lab.client import LabClient

# Counts the page's requestAnimationFrame callbacks in window.__frames from now on.
COUNT_FRAMES = """() => { window.__frames = 0;
  const step = () => { window.__frames += 1; requestAnimationFrame(step); };
  requestAnimationFrame(step); }"""


def window_on_time(first: dict, last: dict) -> float:
    """The loop's on-time fraction between two telemetry messages' cumulative statistics."""
    ticks = last["ticks"] - first["ticks"]
    on_time = last["on_time_fraction"] * last["ticks"] - first["on_time_fraction"] * first["ticks"]
    return on_time / ticks if ticks else 1.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pages", type=int, default=10)
    parser.add_argument("--subscribers", type=int, default=5)
    parser.add_argument("--duration", type=float, default=30.0, help="measured window (s)")
    parser.add_argument("--robot", default="anymal")
    args = parser.parse_args()
    from playwright.sync_api import sync_playwright

    log = Path(os.environ.get("TMPDIR", "/tmp")) / f"bench_load_{os.getpid()}.log"
    server = LabServe(log, "--robot", args.robot)
    subscribers: list[LabClient] = []
    try:
        lab = server.client()
        server.wait_ui()
        counts = [0] * args.subscribers
        for i in range(args.subscribers):
            subscriber = LabClient(server.endpoint)
            subscriber.subscribe_telemetry(lambda _, i=i: counts.__setitem__(i, counts[i] + 1))
            subscribers.append(subscriber)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            pages = []
            for _ in range(args.pages):
                page = browser.new_context().new_page()
                page.goto(server.url, wait_until="domcontentloaded", timeout=120_000)
                pages.append(page)
            for page in pages:
                page.evaluate(COUNT_FRAMES)
            first = lab.wait_telemetry()["loop"]
            start, counts_before = time.monotonic(), list(counts)
            frames_before = [page.evaluate("window.__frames") for page in pages]
            time.sleep(args.duration)
            frames = [page.evaluate("window.__frames") for page in pages]
            last = lab.wait_telemetry(lambda m: m["loop"]["ticks"] > first["ticks"])["loop"]
            elapsed = time.monotonic() - start
            fps = sorted((f - b) / elapsed for f, b in zip(frames, frames_before, strict=True))
            browser.close()
        report = {
            "pages": args.pages,
            "subscribers": args.subscribers,
            "window_s": round(elapsed, 1),
            "load_average": os.getloadavg(),
            "loop": {
                "sched": last["sched"],
                "on_time_fraction": round(window_on_time(first, last), 5),
                "ticks": last["ticks"] - first["ticks"],
                "skipped": last["skipped"] - first["skipped"],
                "tick_us": last["tick_us"],
                "lateness_us": last["lateness_us"],
            },
            "page_fps": {"min": round(fps[0], 1), "median": round(fps[len(fps) // 2], 1)},
            "subscriber_hz": [
                round((c - b) / elapsed, 1) for c, b in zip(counts, counts_before, strict=True)
            ],
        }
        print(json.dumps(report))
        lab.close()
    finally:
        for subscriber in subscribers:
            subscriber.close()
        server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
