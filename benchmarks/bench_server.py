"""Benchmark of the realtime lab server (not a test; targets from issue 3):

- command-to-applied latency over loopback: the round trip of a command whose reply the server
  sends only after applying it between two ticks (target p99 <= 5 ms);
- the loop's on-time fraction over `--duration` seconds (target >= 99.9 %) with two telemetry
  subscribers attached and, with `--ui`, the browser UI process.

    .venv/bin/python benchmarks/bench_server.py --duration 60 [--ui] [--gait trot] [--json]
    .venv/bin/python benchmarks/bench_server.py --robot talos --gait stance  # single support
    .venv/bin/python benchmarks/bench_server.py --robot bolt --gait biped_step
    .venv/bin/python benchmarks/bench_server.py --method nullspace --spin-ms auto
    .venv/bin/python benchmarks/bench_server.py --targets --ui   # issue 31's four, in turn

The machine's own floor is measured in the same run: bench_floor.py's empty loop, with the
server's spin setting, for the same duration just before the server (and after it with
`--floor-after`); the report gives both fractions and how many points the server is below the
floor (issue 31: the target is within 0.3 points).

`--gait` picks the situation (GAITS): `stand` (the default; the commands alternate vx between
0 and 0.1 m/s), `trot` and `crawl` (a quadruped walking; vx 0.3 / 0.5 and 0.1 / 0.2 m/s),
`biped_step` (Bolt stepping, Kim's stack; vx 0.15 / 0.25 m/s), `stance` (a flat-footed biped,
Talos, on its left sole: Herzog 2016 §5.4 with the LQR momentum law). `--robot` takes any of
the lab's robots; a gait the robot cannot do is refused by the server, by name. `--targets`
runs issue 31's four situations in turn (ANYmal standing and trotting, Talos in single support,
Bolt with biped_step), each against its own floor, and prints one line each.

`--sections` starts the server through serve_sections.py, which times each tick's parts (the
command intake, the session's tick and its native crossing, the work beside the tick, the rest)
and reports their medians by the tick's kind.

Each run also reports the loop thread's CPU share (its CPU time over the wall time between
two telemetry messages: `loop.cpu_s`), so settings that spin longer show what they cost.
"""

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lab.client import LabClient

STOP_TIMEOUT_S = 60.0  # the server's own shutdown after SIGINT; then it is killed


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def start_server(
    args: argparse.Namespace, robot: str, port: int, log, sections: str | None = None
) -> subprocess.Popen:
    """`lab serve` (through serve_sections.py's timer, writing to `sections`, when given)."""
    serve = ["-m", "lab.runtime.serve"]
    if sections is not None:
        serve = [str(Path(__file__).resolve().parent / "serve_sections.py"), sections]
    cmd = [sys.executable, *serve, "--port", str(port), "--robot", robot]
    cmd += ["--rate", str(args.rate), "--sched", args.sched]
    if args.spin_ms is not None:
        cmd += ["--spin-ms", str(args.spin_ms)]
    cmd += args.serve_arg
    if args.ui:
        cmd += ["--ui-port", str(free_port())]
    else:
        cmd.append("--headless")
    return subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)


def connect(endpoint: str, timeout: float = 60.0) -> LabClient:
    end = time.monotonic() + timeout
    while True:
        try:
            client = LabClient(endpoint, connect_timeout=0.5)
        except Exception:
            if time.monotonic() > end:
                raise
            time.sleep(0.2)
            continue
        if client.command("info", timeout=1.0).get("ok"):
            return client
        client.close()


@dataclass(frozen=True)
class Gait:
    """A situation to hold the server in: the commands that set it up and the two speeds (vx,
    m/s) the timed velocity commands alternate between."""

    setup: tuple[tuple[str, dict], ...]
    speeds: tuple[float, float]


GAITS = {
    "stand": Gait((), (0.0, 0.1)),
    "trot": Gait((("gait", {"name": "trot"}),), (0.3, 0.5)),
    "crawl": Gait((("gait", {"name": "crawl"}),), (0.1, 0.2)),
    "biped_step": Gait((("gait", {"name": "biped_step"}),), (0.15, 0.25)),
    "stance": Gait((("momentum", {"mode": "lqr"}), ("stance", {"side": "left"})), (0.0, 0.1)),
}
# Issue 31's targets: (robot, gait).
TARGETS = (("anymal", "stand"), ("anymal", "trot"), ("talos", "stance"), ("bolt", "biped_step"))


def measure(
    endpoint: str,
    duration: float,
    command_hz: float,
    gait: Gait,
    setup: list[tuple[str, dict]] | None = None,
) -> dict[str, object]:
    counts = [0, 0]
    lock = threading.Lock()

    def counter(i: int):
        def count(_message: dict) -> None:
            with lock:
                counts[i] += 1

        return count

    # connect() waits for the server to start (seconds on a loaded machine); the subscribers,
    # whose clients do not wait as long, connect after it.
    client = connect(endpoint)
    subscribers: list[LabClient] = []
    try:
        subscribers = [LabClient(endpoint) for _ in counts]
        for i, sub in enumerate(subscribers):
            sub.subscribe_telemetry(counter(i))
        client.wait_telemetry(timeout=5.0)
        speeds = gait.speeds
        for verb, payload in [*gait.setup, *(setup or ())]:
            reply = client.command(verb, timeout=5.0, **payload)
            if not reply.get("ok"):
                raise SystemExit(f"{verb} {payload} refused: {reply.get('error')}")
        client.command("velocity", vx=sum(speeds) / 2, timeout=1.0)
        time.sleep(1.0)  # settle after start-up (and into the gait)
        first = client.wait_telemetry()["loop"]
        with lock:
            counts_first = list(counts)
        latencies = []
        failures = 0
        end = time.monotonic() + duration
        next_send = time.monotonic()
        i = 0
        while time.monotonic() < end:
            time.sleep(max(0.0, next_send - time.monotonic()))
            next_send += 1.0 / command_hz
            t0 = time.perf_counter()
            reply = client.command("velocity", vx=speeds[i % 2], timeout=1.0)
            latencies.append(time.perf_counter() - t0)
            failures += not reply.get("ok")
            i += 1
        last = client.wait_telemetry()["loop"]
        with lock:
            received = [c - c0 for c, c0 in zip(counts, counts_first, strict=True)]
        elapsed = time.monotonic() - end + duration
    finally:
        client.close()
        for sub in subscribers:
            sub.close()
    ticks = last["ticks"] - first["ticks"]
    on_time = last["on_time_fraction"] * last["ticks"] - first["on_time_fraction"] * first["ticks"]
    lat_ms = np.array(latencies) * 1e3
    return {
        "duration_s": duration,
        "commands": len(latencies),
        "command_failures": failures,
        "latency_ms": {
            "p50": round(float(np.percentile(lat_ms, 50)), 3),
            "p99": round(float(np.percentile(lat_ms, 99)), 3),
            "max": round(float(lat_ms.max()), 3),
        },
        "ticks": ticks,
        "tick_rate_hz": round(ticks / elapsed, 1),
        "on_time_fraction": round(on_time / ticks, 6),
        "overruns": last["overruns"] - first["overruns"],
        "late_wakeups": last["late_wakeups"] - first["late_wakeups"],
        "late_pushed": last["late_pushed"] - first["late_pushed"],
        "loop_cpu_share": round(
            (last["cpu_s"] - first["cpu_s"]) / (last["clock_s"] - first["clock_s"]), 4
        ),
        "spin_margin_us": last["spin_margin_us"],
        "server_floor": last["floor"],
        "fifo": last["fifo"],
        "sched": last["sched"],
        "slice_us": last.get("slice_us"),
        "nice": last.get("nice"),
        "gc_collections": [
            b - a for a, b in zip(first["gc_collections"], last["gc_collections"], strict=True)
        ],
        "since_start": {
            key: last[key]
            for key in (
                "lateness_us",
                "tick_us",
                "tick_us_by_kind",
                "late_lateness_us",
                "gc_pause_us",
            )
            if key in last
        },
        "telemetry_hz_per_subscriber": [round(c / elapsed, 1) for c in received],
    }


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--duration", type=float, default=60.0, help="s (default: 60)")
    p.add_argument("--robot", default="anymal", help="any of the lab's robots (default: anymal)")
    p.add_argument("--rate", type=float, default=1000.0, help="loop rate, Hz (default: 1000)")
    p.add_argument("--command-hz", type=float, default=50.0, help="commands per second")
    p.add_argument("--ui", action="store_true", help="also run the browser UI process")
    p.add_argument("--gait", choices=list(GAITS), default="stand", help="(default: stand)")
    p.add_argument("--targets", action="store_true", help="issue 31's four situations in turn")
    p.add_argument(
        "--sched", default="auto", help="the server's --sched: auto, fifo or other (default: auto)"
    )
    p.add_argument("--spin-ms", help="the server's --spin-ms, ms or auto (default: its own)")
    p.add_argument(
        "--serve-arg",
        action="append",
        default=[],
        metavar="ARG",
        help="pass ARG on to `lab serve` (repeat; e.g. --serve-arg=--slice-ms=0.1)",
    )
    p.add_argument("--method", help="switch to this hierarchy method (e.g. nullspace, wbosc)")
    p.add_argument("--preset", help="install this stack preset first (e.g. herzog_table4)")
    p.add_argument("--momentum", help="the momentum law (pd or lqr), for the Herzog presets")
    p.add_argument("--stance", help="stand on one sole (left or right; Talos single support)")
    p.add_argument(
        "--no-floor",
        action="store_true",
        help="skip the empty loop (bench_floor.py) run for the same duration just before",
    )
    p.add_argument("--floor-after", action="store_true", help="also run the empty loop after")
    p.add_argument("--json", action="store_true", help="print one JSON object (a list: --targets)")
    p.add_argument(
        "--sections",
        action="store_true",
        help="time each tick's sections in the server (serve_sections.py): median µs by kind",
    )
    args = p.parse_args()
    if args.spin_ms not in (None, "auto"):
        try:
            float(args.spin_ms)
        except ValueError:
            p.error(f"--spin-ms: not a number of ms nor auto: {args.spin_ms!r}")
    cases = TARGETS if args.targets else ((args.robot, args.gait),)
    results = [one_run(args, robot, gait) for robot, gait in cases]
    if args.json:
        print(json.dumps(results if args.targets else results[0]))
        return 0
    if args.targets:
        for r in results:
            print(
                f"{r['robot']:7} {r['gait']:11} on time {r['on_time_fraction']:.3%}, floor "
                f"{r.get('floor_on_time_fraction', float('nan')):.3%} "
                f"({r.get('below_floor_points', float('nan')):+.2f} points below), latency p99 "
                f"{r['latency_ms']['p99']:.2f} ms, loop CPU {r['loop_cpu_share']:.1%}, "
                f"load {r['load']}"
            )
        return 0
    report(results[0], args)
    return 0


def one_run(args: argparse.Namespace, robot: str, gait: str) -> dict:
    """The floor before (unless --no-floor), the server on `robot` in `gait`, the floor after
    (--floor-after): the server's figures with both floors."""
    setup = [
        (verb, payload)
        for verb, payload in (
            ("stack", {"preset": args.preset}),
            ("momentum", {"mode": args.momentum}),
            ("hierarchy", {"method": args.method}),
            ("stance", {"side": args.stance}),
        )
        if next(iter(payload.values())) is not None
    ]
    port = free_port()
    load = os.getloadavg()[0]  # the machine's 1-minute load at the start
    floor = {} if args.no_floor else {"before": _floor(args)}
    with tempfile.TemporaryFile() as log, tempfile.TemporaryDirectory() as tmp:
        sections = Path(tmp) / "sections.json" if args.sections else None
        server = start_server(args, robot, port, log, None if sections is None else str(sections))
        try:
            endpoint = f"tcp/127.0.0.1:{port}"
            result = measure(endpoint, args.duration, args.command_hz, GAITS[gait], setup)
        finally:
            server.send_signal(signal.SIGINT)
            try:  # on a loaded machine (load 40) the server's UI and Zenoh took over 10 s
                server.wait(STOP_TIMEOUT_S)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
        if sections is not None:  # None: the server was killed before it wrote them
            result["sections_us"] = json.loads(sections.read_text()) if sections.exists() else None
    if args.floor_after:
        floor["after"] = _floor(args)
    result["floor"] = floor
    if floor:
        fractions = [run["on_time_fraction"] for run in floor.values()]
        result["floor_on_time_fraction"] = min(fractions)
        result["below_floor_points"] = round(100 * (min(fractions) - result["on_time_fraction"]), 3)
    result["setup"] = [f"{verb} {payload}" for verb, payload in (*GAITS[gait].setup, *setup)]
    result["robot"] = robot
    result["rate_hz"] = args.rate
    result["ui"] = args.ui
    result["gait"] = gait
    result["spin_ms"] = args.spin_ms
    result["serve_args"] = args.serve_arg
    result["load"] = round(load, 2)
    return result


def report(result: dict, args: argparse.Namespace) -> None:
    """The human-readable report of one run."""
    lat = result["latency_ms"]
    ui = "on" if args.ui else "off"
    print(
        f"robot {result['robot']} {result['gait']} at {args.rate:g} Hz, {args.duration:g} s, "
        f"UI {ui}, 2 subscribers"
    )
    print(
        f"command-to-applied latency: p50 {lat['p50']:.2f} ms, p99 {lat['p99']:.2f} ms, "
        f"max {lat['max']:.2f} ms over {result['commands']} commands "
        f"({result['command_failures']} failed)"
    )
    since = result["since_start"]
    print(
        f"loop: {result['tick_rate_hz']} ticks/s, on-time {result['on_time_fraction']:.4%}, "
        f"overruns {result['overruns']}, late ticks: woken late {result['late_wakeups']}, "
        f"after an overrun {result['late_pushed']}; spin margin {result['spin_margin_us']} us, "
        f"loop CPU {result['loop_cpu_share']:.1%}; "
        f"SCHED_{result['sched'].upper()} (slice {result['slice_us']} us, nice {result['nice']}); "
        "since start: lateness "
        f"p50 {since['lateness_us']['p50']} us p99 {since['lateness_us']['p99']} us "
        f"max {since['lateness_us']['max']} us, tick p50 {since['tick_us']['p50']} us "
        f"p99 {since['tick_us']['p99']} us"
    )
    kinds = since.get("tick_us_by_kind", {})
    print("tick p50 by kind (us): " + ", ".join(f"{k} {v['p50']}" for k, v in kinds.items()))
    late = since.get("late_lateness_us", {})
    print(
        "lateness of late ticks p50/p99 (us): "
        + ", ".join(f"{k} {v['p50']}/{v['p99']}" for k, v in late.items())
        + f"; GC collections by generation {result['gc_collections']}, load {result['load']}"
    )
    print(f"telemetry per subscriber: {result['telemetry_hz_per_subscriber']} Hz")
    for kind, us in (result.get("sections_us") or {}).items():
        print(f"{kind} ticks, median us: " + ", ".join(f"{k} {v}" for k, v in us.items()))
    if server_floor := result["server_floor"]:
        print(f"the server's own floor at start-up: {server_floor['on_time_fraction']:.4%}")
    if floor := result["floor"]:
        below = result["below_floor_points"]
        runs = ", ".join(f"{when} {run['on_time_fraction']:.4%}" for when, run in floor.items())
        print(
            f"the machine's floor (the empty loop, same settings, same duration): {runs}; "
            f"the server is {abs(below):.2f} points {'below' if below > 0 else 'above'} the "
            "lower one"
        )


def _floor(args: argparse.Namespace) -> dict:
    """The empty loop of bench_floor.py for `args.duration`, with the server's spin setting."""
    from bench_floor import empty_loop

    if args.spin_ms is None:
        settings = {}
    elif args.spin_ms == "auto":
        settings = {"adaptive_spin": True}
    else:
        settings = {"spin_s": float(args.spin_ms) / 1000.0, "adaptive_spin": False}
    return empty_loop(args.duration, **settings)


if __name__ == "__main__":
    sys.exit(main())
