"""Benchmark of what the 1 kHz loop leaves to the rest of the machine (not a test; issue 16).

Starts `lab serve` (sim loop + UI process) with the given scheduling, optionally a CPU hog pinned
to CPU 0, and Debian's headless Chromium on the page; then times, alternating, `--actions` times:
- a command round trip from a second process (LabClient `info`);
- a page action: a click on Pause / Resume in the page until `info` reports it applied.

    .venv/bin/python benchmarks/bench_starvation.py --sched fifo --spin-ms 0 [--hog] [--json]
    .venv/bin/python benchmarks/bench_starvation.py --spin-ms auto   # the adaptive margin

It also reports the loop's on-time fraction and its thread's CPU share (`loop.cpu_s` over the
loop's clock) over the clicks.
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.helpers.browser import CHROMIUM, CHROMIUM_ARGS, LabServe, require_chromium

ACTION_TIMEOUT_S = 60.0


def wait_paused(client, paused: bool) -> float:
    """Seconds until `info` reports `paused` (ACTION_TIMEOUT_S if it never does)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < ACTION_TIMEOUT_S:
        if client.command("info", timeout=5.0).get("paused") == paused:
            return time.monotonic() - t0
        time.sleep(0.01)
    return ACTION_TIMEOUT_S


def summary(seconds: list[float]) -> dict[str, float]:
    ms = np.array(seconds) * 1e3
    return {
        "p50": round(float(np.percentile(ms, 50)), 1),
        "p90": round(float(np.percentile(ms, 90)), 1),
        "max": round(float(ms.max()), 1),
    }


def measure(args: argparse.Namespace, log: Path) -> dict[str, object]:
    from playwright.sync_api import sync_playwright

    serve_args = ["--robot", "anymal", "--sched", args.sched]
    if args.spin_ms is not None:
        serve_args += ["--spin-ms", str(args.spin_ms)]
    server = LabServe(log, *serve_args)
    hog = client = None
    try:
        client = server.client()
        server.wait_ui()
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1400, "height": 800})
            page.set_default_timeout(120_000)
            page.goto(server.url)
            page.get_by_text("You hold control").wait_for()
            time.sleep(3.0)  # the page settles (3-D view loaded)
            if args.hog:
                hog = subprocess.Popen(
                    ["taskset", "-c", "0", sys.executable, "-c", "while True: pass"]
                )
                time.sleep(1.0)
            first = client.command("info", timeout=5.0)["loop"]
            commands, clicks = [], []
            for i in range(args.actions):
                t0 = time.monotonic()
                client.command("info", timeout=10.0)
                commands.append(time.monotonic() - t0)
                button = "Pause" if i % 2 == 0 else "Resume"
                page.get_by_role("button", name=button, exact=True).dispatch_event("click")
                clicks.append(wait_paused(client, button == "Pause"))
                time.sleep(0.3)
            last = client.command("info", timeout=5.0)["loop"]
            browser.close()
    finally:
        if client is not None:  # its Zenoh session's threads would keep the process alive
            client.close()
        if hog is not None:
            hog.kill()
            hog.wait()
        server.stop()
    ticks = last["ticks"] - first["ticks"]
    on_time = last["on_time_fraction"] * last["ticks"] - first["on_time_fraction"] * first["ticks"]
    cpu_share = (last["cpu_s"] - first["cpu_s"]) / (last["clock_s"] - first["clock_s"])
    return {
        "sched": last["sched"],
        "spin_ms": args.spin_ms,
        "hog": args.hog,
        "command_ms": summary(commands),
        "click_ms": summary(clicks),
        "on_time_fraction": round(on_time / max(1, ticks), 5),
        "late_wakeups": last["late_wakeups"] - first["late_wakeups"],
        "overruns": last["overruns"] - first["overruns"],
        "ticks": ticks,
        "loop_cpu_share": round(cpu_share, 4),
        "spin_margin_us": last["spin_margin_us"],
    }


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--sched", default="auto", help="the server's --sched (default: auto)")
    p.add_argument("--spin-ms", help="the server's --spin-ms, ms or auto (default: its own)")
    p.add_argument("--hog", action="store_true", help="a busy Python loop pinned to CPU 0")
    p.add_argument("--actions", type=int, default=20, help="clicks and commands (default: 20)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args()
    require_chromium("bench_starvation.py")
    with tempfile.TemporaryDirectory() as tmp:
        result = measure(args, Path(tmp) / "serve.log")
    if args.json:
        print(json.dumps(result))
    else:
        c, k = result["command_ms"], result["click_ms"]
        print(
            f"SCHED_{result['sched'].upper()} spin {args.spin_ms} ms, hog {args.hog}: command "
            f"p50 {c['p50']} p90 {c['p90']} max {c['max']} ms; click p50 {k['p50']} "
            f"p90 {k['p90']} max {k['max']} ms; on time {result['on_time_fraction']:.3%}, loop "
            f"CPU {result['loop_cpu_share']:.1%} (margin {result['spin_margin_us']} us)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
