"""The 1 kHz loop's floor on this machine: how many ticks the lab's own loop gets on time with
nothing to do (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_floor.py [--seconds 20] [--rounds 2] [--json]

`benchmarks/bench_server.py` counts a tick on time when it starts at most 10 % of a period after
its deadline. Part of what it misses is not the lab's: on a virtual machine the host decides
when a halted vCPU wakes, and when a running one is taken away. This benchmark separates that
part out by running `SimLoop` with an empty session (its tick, telemetry and drawing state do
nothing, the transport drops what it is given) under each loop setting in turn, `--rounds`
times, alternated:

- `default`: the server's defaults (sleep, then a short busy spin; the EEVDF slice and the nice
  value it asks for);
- `nice 0`: the same without the raised priority;
- `adaptive`: the wake-up margin learned (`lab serve --spin-ms auto`, lab/runtime/wake_margin.py);
- `whole period`: never sleep (spin the whole period: one CPU kept busy);
- `whole period, nice 0`.

Then `spinning thread`: a thread that only reads the clock for `--seconds`, counting the gaps
longer than 10 % of a period (the vCPU was taken away, or an interrupt ran long): the share of
periods with such a gap bounds what any loop on this machine can reach. With `--cyclictest`
and Debian's rt-tests installed, the same 1 kHz wake-up is measured by `cyclictest` too
(SCHED_OTHER and SCHED_FIFO), the standard tool, for a reference that is not Python.
"""

import argparse
import json
import math
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable

from lab.runtime.deadline_stats import ON_TIME_TOLERANCE
from lab.runtime.loop import LoopConfig, SimLoop

PERIOD_S = 1e-3
SETTINGS = {
    "default": {},
    "nice 0": {"nice": 0},
    "adaptive": {"adaptive_spin": True},
    "whole period": {"spin_s": PERIOD_S},
    "whole period, nice 0": {"spin_s": PERIOD_S, "nice": 0},
}


class EmptySession:
    """A session with nothing to do: what is left of a tick is the loop's own bookkeeping."""

    def tick(self) -> None:
        pass

    def handle(self, verb: str, payload: object) -> dict:
        return {"ok": True}

    def telemetry(self) -> dict:
        return {"t": 0.0}

    def telemetry_in_two(self) -> tuple[dict, Callable[[], None]]:
        return self.telemetry(), lambda: None

    def warm(self) -> bool:
        return False

    def drawing_state(self) -> dict:
        return {}

    def pop_events(self) -> list[dict]:
        return []


class DroppingTransport:
    """Receives nothing, drops what it is given."""

    def rejections(self) -> tuple[int, str, str]:
        return (0, "", "")

    def receive(self) -> None:
        return None

    def reply(self, request: object, body: dict) -> None:
        pass

    def publish_telemetry(self, message: dict) -> None:
        pass

    def publish_state(self, message: dict) -> None:
        pass

    def publish_event(self, message: dict) -> None:
        pass


def empty_loop(seconds: float, **settings: object) -> dict:
    """Run the loop with an empty session for `seconds`; its deadline statistics."""
    loop = SimLoop(EmptySession(), DroppingTransport(), LoopConfig(sched="other", **settings))
    stop = threading.Event()
    thread = threading.Thread(target=loop.run, args=(stop,), name="empty loop")
    thread.start()
    time.sleep(seconds)
    stop.set()
    thread.join()
    if loop.error is not None:
        raise loop.error
    loop.stats.refresh_percentiles()
    snapshot = loop.stats.snapshot()
    return {
        "ticks": snapshot["ticks"],
        "on_time_fraction": round(snapshot["on_time_fraction"], 6),
        "late_wakeups": snapshot["late_wakeups"],
        "overruns": snapshot["overruns"],
        "lateness_us": snapshot["lateness_us"],
        "nice": snapshot["nice"],
        "slice_us": snapshot["slice_us"],
    }


def spinning_thread(seconds: float) -> dict:
    """Read the clock for `seconds`; the share of periods in which it stopped for longer than the
    on-time tolerance, and the longest stop."""
    threshold = ON_TIME_TOLERANCE * PERIOD_S
    clock = time.monotonic
    start = last = clock()
    gaps: list[float] = []
    while last - start < seconds:
        now = clock()
        if now - last > threshold:
            gaps.append(now - last)
        last = now
    periods = seconds / PERIOD_S
    return {
        "periods_with_a_long_gap": round(len(gaps) / periods, 6),
        "gaps": len(gaps),
        "longest_gap_us": round(max(gaps, default=0.0) * 1e6, 1),
    }


def cyclictest(seconds: float, policy: str) -> dict | None:
    """Debian rt-tests' `cyclictest` at 1 kHz: the share of wake-ups later than the tolerance
    (None when it is not installed)."""
    if shutil.which("cyclictest") is None:
        return None
    limit_us = ON_TIME_TOLERANCE * PERIOD_S * 1e6
    cmd = ["cyclictest", "-m", "-q", "-i", str(round(PERIOD_S * 1e6))]
    cmd += ["-D", str(math.ceil(seconds)), f"--policy={policy}", "-h", "10000"]
    cmd += ["-p", "50"] if policy == "fifo" else []
    out = subprocess.run(cmd, capture_output=True, text=True, check=False).stdout
    total = late = maximum = 0
    for line in out.splitlines():
        if line.startswith("# Max Latencies:"):
            maximum = int(line.split(":")[1])
        elif line.startswith("# Histogram Overflows:"):  # later than the histogram's 10 ms
            overflows = int(line.split(":")[1])
            total, late = total + overflows, late + overflows
        elif line.strip() and not line.startswith("#"):
            latency_us, count = (int(field) for field in line.split()[:2])
            total += count
            late += count if latency_us > limit_us else 0
    return {
        "wakeups": total,
        "on_time_fraction": round(1 - late / total, 6) if total else None,
        "max_us": maximum,
    }


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--seconds", type=float, default=20.0, help="per setting and round")
    p.add_argument("--rounds", type=int, default=2, help="the settings, alternated this often")
    p.add_argument("--cyclictest", action="store_true", help="also run rt-tests' cyclictest")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    args = p.parse_args()
    runs: dict[str, list[dict]] = {name: [] for name in SETTINGS}
    for _ in range(args.rounds):
        for name, settings in SETTINGS.items():
            runs[name].append(empty_loop(args.seconds, **settings))
    result: dict[str, object] = {
        "empty_loop": runs,
        "spinning_thread": spinning_thread(args.seconds),
    }
    if args.cyclictest:
        result["cyclictest"] = {
            policy: cyclictest(args.seconds, policy) for policy in ("other", "fifo")
        }
    if args.json:
        print(json.dumps(result))
        return 0
    print(f"the loop with an empty session at 1 kHz, {args.seconds:g} s per run, on time per run:")
    for name, results in runs.items():
        fractions = ", ".join(f"{r['on_time_fraction']:.3%}" for r in results)
        late = ", ".join(f"{r['late_wakeups']}" for r in results)
        nice = results[0]["nice"]
        print(f"  {name:22} {fractions}  (late wake-ups {late}; nice granted: {nice})")
    spin = result["spinning_thread"]
    print(
        f"spinning thread: {spin['periods_with_a_long_gap']:.3%} of periods had a stop longer "
        f"than {ON_TIME_TOLERANCE * PERIOD_S * 1e6:g} us ({spin['gaps']}; longest "
        f"{spin['longest_gap_us']} us)"
    )
    for policy, ct in result.get("cyclictest", {}).items():
        if ct is None:
            print("cyclictest: not installed (Debian's rt-tests)")
            break
        print(
            f"cyclictest SCHED_{policy.upper()}: {ct['on_time_fraction']:.3%} of "
            f"{ct['wakeups']} wake-ups on time, max {ct['max_us']} us"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
