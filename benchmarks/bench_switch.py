"""What a robot switch costs the realtime loop (not a test): the loop at 1 kHz (SCHED_OTHER)
switching between two robots every `--every` s, with the switch built beside the loop
(lab/runtime/switch.py, as `lab serve` does) or on the loop's thread (as before); prints, for
each, the ticks skipped, the on-time fraction and the worst lateness over the run, and the
resident memory before and after.

    .venv/bin/python benchmarks/bench_switch.py [--switches 10] [--every 2] [--robots solo12,bolt]
"""

import argparse
import json
import sys
import threading
import time
from pathlib import Path

from lab.protocol import RobotCommand
from lab.runtime.intake import Request
from lab.runtime.loop import LoopConfig, SimLoop
from lab.runtime.switch import Switcher
from lab.world.session import Session, SessionConfig


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


class Switching:
    """A transport that asks for a switch to the next robot every `every` s, `count` times."""

    def __init__(self, robots: list[str], every: float, count: int, stop: threading.Event) -> None:
        self.robots, self.every, self.left, self.stop = robots, every, count, stop
        self.next_at = time.monotonic() + every
        self.waiting = False
        self.errors: list[str] = []

    def receive(self) -> Request | None:
        if self.waiting or time.monotonic() < self.next_at:
            return None
        name = self.robots[self.left % len(self.robots)]
        self.waiting = True
        return Request("robot", {"name": name}, None, None, RobotCommand(name))

    def rejections(self) -> tuple[int, str, str]:
        return (0, "", "")

    def reply(self, request: Request, body: dict) -> None:
        if not body.get("ok"):
            self.errors.append(str(body))
        self.waiting, self.left = False, self.left - 1
        self.next_at = time.monotonic() + self.every
        if self.left == 0:
            self.stop.set()

    def publish_telemetry(self, message: dict) -> None: ...
    def publish_state(self, message: dict) -> None: ...
    def publish_event(self, message: dict) -> None: ...


def run(beside: bool, robots: list[str], every: float, count: int) -> dict:
    session = Session(SessionConfig(robot=robots[0]))
    stop = threading.Event()
    transport = Switching(robots, every, count, stop)
    switcher = Switcher() if beside else None
    loop = SimLoop(session, transport, LoopConfig(sched="other"), switcher=switcher)
    before = rss_mb()
    loop.run(stop)
    if switcher is not None:
        switcher.close()
    stats = loop.stats
    return {
        "built": "beside the loop" if beside else "on the loop",
        "error": None if loop.error is None else repr(loop.error),
        "refused": transport.errors,
        "ticks": stats.ticks,
        "skipped": stats.skipped,
        "on_time_fraction": round(stats.on_time / max(1, stats.ticks), 4),
        "lateness_us": {
            "p50": round(stats.lateness.percentile(50) * 1e6, 1),
            "p99": round(stats.lateness.percentile(99) * 1e6, 1),
            "max": round(stats.lateness.max * 1e6, 1),
        },
        "rss_mb": {"before": round(before, 1), "after": round(rss_mb(), 1)},
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--switches", type=int, default=10)
    parser.add_argument("--every", type=float, default=2.0, help="s between switches")
    parser.add_argument("--robots", default="solo12,bolt")
    args = parser.parse_args()
    robots = args.robots.split(",")
    for beside in (True, False):
        print(json.dumps(run(beside, robots, args.every, args.switches)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
