"""Load benchmark (not a test, not in CI): what clients cost the sim loop (issue 25).

`lab serve --headless` on a free port, then phases of `--duration` s each, measured from the
loop's own statistics in telemetry and the sim process's resident memory (/proc):

- `quiet`: no client but the observer: the loop's on-time fraction to compare with;
- `flood`: `--flooders` processes each sending commands of `--flood-kb` KB arrays (refused by
  the server) as fast as their Zenoh session allows, up to 32 queries in flight each;
- `after`: quiet again: is the memory the flood took given back;
- `normal`: `--subscribers` telemetry subscribers and `--commanders` clients sending a velocity
  command at `--command-hz` each; their command latency (query to reply) median and p99.

Targets (issue 25): the flooded loop within 2 points of `quiet`; RSS growth under 5 % over the
flood and back after it; `normal` within 2 points of `quiet` and latency p99 <= 10 ms.

    .venv/bin/python benchmarks/bench_load.py [--duration 20] [--robot solo12] [--pages 0]

With `--pages N` it also opens N headless Chromium pages on the UI (Debian's Chromium through
playwright, as the browser tests do) during `normal`, and reports their frame rate.
"""

import argparse
import json
import multiprocessing
import os
import statistics
import sys
import threading
import time
from collections import deque
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from lab.client import LabClient
from lab.client_core import client_id, open_session
from lab.protocol import LabKeys
from tests.helpers.browser import CHROMIUM, CHROMIUM_ARGS, LabServe

IN_FLIGHT = 32  # queries a flooding client keeps unanswered at most
# Counts the page's requestAnimationFrame callbacks in window.__frames from now on.
COUNT_FRAMES = """() => { window.__frames = 0;
  const step = () => { window.__frames += 1; requestAnimationFrame(step); };
  requestAnimationFrame(step); }"""


def window_on_time(first: dict, last: dict) -> float:
    """The loop's on-time fraction between two telemetry messages' cumulative statistics."""
    ticks = last["ticks"] - first["ticks"]
    on_time = last["on_time_fraction"] * last["ticks"] - first["on_time_fraction"] * first["ticks"]
    return on_time / ticks if ticks else 1.0


def rss_mb(pid: int) -> float:
    """Resident memory of process `pid` (MB)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError(f"no VmRSS for {pid}")


def flood(endpoint: str, lab_id: str, kb: int, stop: object, replies: object) -> None:
    """One flooding client (its own process): `gains` commands whose `kp` is a `kb` KB array,
    as fast as replies come back, IN_FLIGHT queries at most in flight; counts the replies in
    `replies` (a multiprocessing Value) until `stop` (a multiprocessing Event) is set."""
    session = open_session(endpoint, 10.0)
    key = LabKeys(lab_id).cmd("gains")
    payload = json.dumps({"task": "posture", "kp": [1.0] * (kb * 1024 // 5)}).encode()
    attachment = client_id(session)
    waiting: deque = deque()
    try:
        while not stop.is_set():
            waiting.append(session.get(key, payload=payload, timeout=2.0, attachment=attachment))
            if len(waiting) >= IN_FLIGHT:
                for reply in waiting.popleft():
                    if reply.ok is not None:
                        with replies.get_lock():
                            replies.value += 1
    finally:
        session.close()


def measure(lab: LabClient, pid: int, seconds: float) -> dict:
    """The loop's on-time fraction and the process's RSS over `seconds` from now."""
    first = lab.wait_telemetry()["loop"]
    rss_before = rss_mb(pid)
    samples = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        time.sleep(min(1.0, max(0.0, end - time.monotonic())))
        samples.append(rss_mb(pid))
    last = lab.wait_telemetry(lambda m: m["loop"]["ticks"] > first["ticks"], timeout=30.0)["loop"]
    return {
        "on_time_fraction": round(window_on_time(first, last), 4),
        "ticks": last["ticks"] - first["ticks"],
        "skipped": last["skipped"] - first["skipped"],
        "tick_us": last["tick_us"],
        "rss_mb": {"start": round(rss_before, 1), "end": round(samples[-1], 1)},
        "rss_max_mb": round(max(samples), 1),
        # the RSS at each tenth of the phase: a flood's first seconds fill Zenoh's buffers, so
        # growth over the phase reads from the first tenth on
        "rss_mb_by_tenth": [round(samples[len(samples) * k // 10], 1) for k in range(10)],
    }


def commander(endpoint: str, hz: float, stop: threading.Event, latencies: list[float]) -> None:
    """One commanding client: a velocity command every 1/hz s, each reply's latency kept."""
    with LabClient(endpoint) as client:
        period = 1.0 / hz
        deadline = time.monotonic()
        while not stop.is_set():
            start = time.monotonic()
            reply = client.command("velocity", vx=0.1)
            if reply.get("ok"):
                latencies.append(time.monotonic() - start)
            deadline += period
            time.sleep(max(0.0, deadline - time.monotonic()))


def percentiles_ms(values: list[float]) -> dict[str, float]:
    """Median and p99 (ms) of `values` (s)."""
    if not values:
        return {"n": 0}
    ordered = sorted(values)
    p99 = ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))]
    return {
        "n": len(values),
        "p50": round(statistics.median(ordered) * 1e3, 2),
        "p99": round(p99 * 1e3, 2),
    }


def normal_load(server: LabServe, lab: LabClient, args: argparse.Namespace) -> dict:
    """10 subscribers and 3 commanders at 50 Hz (by default), and `--pages` browser pages."""
    subscribers = []
    counts = [0] * args.subscribers
    for i in range(args.subscribers):
        subscriber = LabClient(server.endpoint)
        subscriber.subscribe_telemetry(lambda _, i=i: counts.__setitem__(i, counts[i] + 1))
        subscribers.append(subscriber)
    stop, latencies = threading.Event(), []
    threads = [
        threading.Thread(target=commander, args=(server.endpoint, args.command_hz, stop, latencies))
        for _ in range(args.commanders)
    ]
    for thread in threads:
        thread.start()
    pages: dict = {}
    try:
        if args.pages:
            pages = with_pages(server, lab, args)
        else:
            time.sleep(1.0)  # the commanders connected
            before = list(counts)
            pages = {"measured": measure(lab, server.process.pid, args.duration)}
            pages["subscriber_hz"] = [
                round((c - b) / args.duration, 1) for c, b in zip(counts, before, strict=True)
            ]
    finally:
        stop.set()
        for thread in threads:
            thread.join()
        for subscriber in subscribers:
            subscriber.close()
    return {**pages, "command_latency_ms": percentiles_ms(latencies)}


def with_pages(server: LabServe, lab: LabClient, args: argparse.Namespace) -> dict:
    """`measure` with `--pages` Chromium pages open on the UI; their frame rates."""
    from playwright.sync_api import sync_playwright

    server.wait_ui()
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        pages = []
        for _ in range(args.pages):
            page = browser.new_context().new_page()
            page.goto(server.url, wait_until="domcontentloaded", timeout=120_000)
            pages.append(page)
        for page in pages:
            page.evaluate(COUNT_FRAMES)
        start = time.monotonic()
        measured = measure(lab, server.process.pid, args.duration)
        frames = [page.evaluate("window.__frames") for page in pages]
        elapsed = time.monotonic() - start
        browser.close()
    fps = sorted(f / elapsed for f in frames)
    return {
        "measured": measured,
        "page_fps": {"min": round(fps[0], 1), "median": round(fps[len(fps) // 2], 1)},
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=20.0, help="each phase (s)")
    parser.add_argument("--robot", default="solo12")
    parser.add_argument("--flooders", type=int, default=5)
    parser.add_argument("--flood-kb", type=int, default=64)
    parser.add_argument("--subscribers", type=int, default=10)
    parser.add_argument("--commanders", type=int, default=3)
    parser.add_argument("--command-hz", type=float, default=50.0)
    parser.add_argument("--pages", type=int, default=0, help="browser pages during `normal`")
    parser.add_argument("--phases", default="quiet,flood,after,normal")
    parser.add_argument(
        "--serve-args", default="", help="more `lab serve` options, e.g. '--switch-interval-ms 0'"
    )
    args = parser.parse_args()
    log = Path(os.environ.get("TMPDIR", "/tmp")) / f"bench_load_{os.getpid()}.log"
    extra = () if args.pages else ("--headless",)
    server = LabServe(log, "--robot", args.robot, *extra, *args.serve_args.split())
    report: dict = {"robot": args.robot, "duration_s": args.duration, "serve": args.serve_args}
    try:
        lab = server.client()
        pid = server.process.pid
        for phase in args.phases.split(","):
            if phase == "flood":
                spawn = multiprocessing.get_context("spawn")
                stop, replies = spawn.Event(), spawn.Value("l", 0)
                flooders = [
                    spawn.Process(
                        target=flood,
                        args=(server.endpoint, lab.lab_id, args.flood_kb, stop, replies),
                    )
                    for _ in range(args.flooders)
                ]
                for process in flooders:
                    process.start()
                time.sleep(2.0)  # they connected and flood
                before = replies.value
                report[phase] = measure(lab, pid, args.duration)
                rate = (replies.value - before) / args.duration
                report[phase]["flood_replies_per_s"] = round(rate)
                stop.set()
                for process in flooders:
                    process.join(30.0)
                    if process.is_alive():
                        process.kill()
            elif phase == "normal":
                report[phase] = normal_load(server, lab, args)
            else:
                report[phase] = measure(lab, pid, args.duration)
        report["load_average"] = os.getloadavg()
        print(json.dumps(report))
        lab.close()
    finally:
        server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
