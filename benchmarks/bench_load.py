"""Load benchmark (not a test, not in CI): what clients cost the sim loop (issue 25).

`lab serve --headless` on a free port, then phases of `--duration` s each, measured from the
loop's own statistics in telemetry and the sim process's resident memory (/proc):

- `quiet`: no client but the observer: the loop's on-time fraction to compare with;
- `flood`: `--flooders` processes each sending commands of `--flood-kb` KB arrays (refused by
  the server) as fast as their Zenoh session allows, up to 32 queries in flight each;
- `after`: quiet again: is the memory the flood took given back;
- `normal`: `--subscribers` telemetry subscribers and `--commanders` clients sending a velocity
  command at `--command-hz` each; their command latency (query to reply) median and p99.

With `--floor`, each phase also runs benchmarks/bench_floor.py's empty loop (the loop with
nothing to do, in a process of its own) beside the lab for the same seconds: the machine's
share. It shares the machine with the flood and the sim process's threads but not the sim
process (its GIL), and sees the same load at the same time, so the lab's own cost of a phase is
how much more its on-time fraction falls than the floor's (`own_cost_points`, against the
first phase), whatever the machine's load did meanwhile.

Each phase reports the sim process's CPU time by thread (`cpu_ms_per_s`: ms of CPU per second,
by OS thread name; Zenoh's threads are named by Zenoh, the lab's after their Python names) and
a flood the queries its clients sent and the replies they got per second (the rest were dropped
by the server's ring or timed out).

Targets (issue 25): the flooded loop within 2 points of `quiet`; RSS growth under 5 % over the
flood and back after it; `normal` within 2 points of `quiet` and latency p99 <= 10 ms.

    .venv/bin/python benchmarks/bench_load.py [--duration 20] [--robot solo12] [--pages 0]

With `--pages N` it also opens N headless Chromium pages on the UI (Debian's Chromium through
playwright, as the browser tests do) during `normal`, and reports their frame rate.
"""

import argparse
import contextlib
import json
import multiprocessing
import multiprocessing.pool
import os
import re
import statistics
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Iterator
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from benchmarks.bench_floor import empty_loop
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


def thread_cpu_s(pid: int) -> Counter[str]:
    """CPU time (s, user + system) of process `pid`'s threads so far, summed by thread name
    (digits dropped: Zenoh's `rx-0`, `rx-1`... count as `rx-`)."""
    ticks = os.sysconf("SC_CLK_TCK")
    cpu: Counter[str] = Counter()
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(FileNotFoundError):  # the thread ended meanwhile
            stat = (task / "stat").read_text()
            name = re.sub(r"\d+", "", stat[stat.index("(") + 1 : stat.rindex(")")])
            fields = stat[stat.rindex(")") + 2 :].split()
            cpu[name] += (int(fields[11]) + int(fields[12])) / ticks  # utime, stime
    return cpu


def flood(endpoint: str, lab_id: str, kb: int, stop: object, sent: object, replies: object) -> None:
    """One flooding client (its own process): `gains` commands whose `kp` is a `kb` KB array,
    as fast as replies come back, IN_FLIGHT queries at most in flight; counts the queries in
    `sent` and the replies in `replies` (multiprocessing Values) until `stop` (a
    multiprocessing Event) is set."""
    session = open_session(endpoint, 10.0)
    key = LabKeys(lab_id).cmd("gains")
    payload = json.dumps({"task": "posture", "kp": [1.0] * (kb * 1024 // 5)}).encode()
    attachment = client_id(session)
    waiting: deque = deque()
    try:
        while not stop.is_set():
            waiting.append(session.get(key, payload=payload, timeout=2.0, attachment=attachment))
            with sent.get_lock():
                sent.value += 1
            if len(waiting) >= IN_FLIGHT:
                for reply in waiting.popleft():
                    if reply.ok is not None:
                        with replies.get_lock():
                            replies.value += 1
    finally:
        session.close()


@contextlib.contextmanager
def flooding(endpoint: str, lab_id: str, args: argparse.Namespace) -> Iterator[dict]:
    """`--flooders` flooding processes aimed at the lab `lab_id`, from two seconds after they
    start (they connected) until the block ends; the dict yielded gets the queries sent and the
    replies received per second."""
    spawn = multiprocessing.get_context("spawn")
    stop, sent, replies = spawn.Event(), spawn.Value("l", 0), spawn.Value("l", 0)
    flooders = [
        spawn.Process(target=flood, args=(endpoint, lab_id, args.flood_kb, stop, sent, replies))
        for _ in range(args.flooders)
    ]
    for process in flooders:
        process.start()
    time.sleep(2.0)  # they connected and flood
    counts: dict = {}
    before, start = (sent.value, replies.value), time.monotonic()
    try:
        yield counts
    finally:
        elapsed = time.monotonic() - start
        counts["flood_sent_per_s"] = round((sent.value - before[0]) / elapsed)
        counts["flood_replies_per_s"] = round((replies.value - before[1]) / elapsed)
        stop.set()
        for process in flooders:
            process.join(30.0)
            if process.is_alive():
                process.kill()


def measure(
    lab: LabClient, pid: int, seconds: float, floor: multiprocessing.pool.Pool | None = None
) -> dict:
    """The loop's on-time fraction, its tick's statistics, the process's RSS and its threads'
    CPU time over `seconds` from now; with `floor` (a pool of one spawned process), the empty
    loop's statistics over the same seconds beside it."""
    beside = None if floor is None else floor.apply_async(empty_loop, (seconds,))
    first = lab.wait_telemetry()["loop"]
    rss_before, cpu_before, start = rss_mb(pid), thread_cpu_s(pid), time.monotonic()
    samples = []
    end = start + seconds
    while time.monotonic() < end:
        time.sleep(min(1.0, max(0.0, end - time.monotonic())))
        samples.append(rss_mb(pid))
    cpu = thread_cpu_s(pid)
    cpu.subtract(cpu_before)
    elapsed = time.monotonic() - start
    last = lab.wait_telemetry(lambda m: m["loop"]["ticks"] > first["ticks"], timeout=30.0)["loop"]
    floor_result = {} if beside is None else {"floor": beside.get(60.0)}
    return {
        **floor_result,
        "on_time_fraction": round(window_on_time(first, last), 4),
        "ticks": last["ticks"] - first["ticks"],
        "skipped": last["skipped"] - first["skipped"],
        "tick_us": last["tick_us"],
        "rss_mb": {"start": round(rss_before, 1), "end": round(samples[-1], 1)},
        "rss_max_mb": round(max(samples), 1),
        # the RSS at each tenth of the phase: a flood's first seconds fill Zenoh's buffers, so
        # growth over the phase reads from the first tenth on
        "rss_mb_by_tenth": [round(samples[len(samples) * k // 10], 1) for k in range(10)],
        "cpu_ms_per_s": {
            name: round(s * 1e3 / elapsed, 1) for name, s in cpu.most_common() if s > 0.0
        },
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


def own_cost(report: dict, phases: list[str]) -> None:
    """Each phase's `own_cost_points`: how many points more the lab's on-time fraction fell
    from the first phase's than the floor's beside it did (the machine's share taken out)."""

    def gap(phase: str) -> float:
        measured = report[phase].get("measured", report[phase])
        return measured["floor"]["on_time_fraction"] - measured["on_time_fraction"]

    for phase in phases[1:]:
        if "page_fps" not in report[phase]:  # with browser pages no floor runs beside
            report[phase]["own_cost_points"] = round((gap(phase) - gap(phases[0])) * 100, 2)


def normal_load(
    server: LabServe,
    lab: LabClient,
    args: argparse.Namespace,
    floor: multiprocessing.pool.Pool | None = None,
) -> dict:
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
            pages = {"measured": measure(lab, server.process.pid, args.duration, floor)}
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
        "--floor", action="store_true", help="bench_floor.py's empty loop beside each phase"
    )
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
        floor = multiprocessing.get_context("spawn").Pool(1) if args.floor else None
        for phase in args.phases.split(","):
            if phase == "flood":
                with flooding(server.endpoint, lab.lab_id, args) as counts:
                    report[phase] = measure(lab, pid, args.duration, floor)
                report[phase].update(counts)
            elif phase == "normal":
                report[phase] = normal_load(server, lab, args, floor)
            else:
                report[phase] = measure(lab, pid, args.duration, floor)
        if floor is not None:
            floor.close()
            own_cost(report, args.phases.split(","))
        report["load_average"] = os.getloadavg()
        print(json.dumps(report))
        lab.close()
    finally:
        server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
