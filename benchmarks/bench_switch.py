"""What a robot switch costs the realtime loop (not a test): the loop at 1 kHz (SCHED_OTHER,
or `--loop-sched fifo`) switching between robots every `--every` s, in one run for each way of
building the switch:

- `worker`: the robot and MuJoCo's model built in a worker process and kept per robot and
  scene (lab/runtime/world_cache.py), the rest of the session's parts on a thread beside the
  loop, swapped in between two ticks (`Switcher(worker=True)`);
- `thread`: the whole build on the thread beside the loop, as `lab serve` does
  (lab/runtime/switch.py), the thread and the loop's at SCHED_FIFO while a switch is under way
  (`--realtime on`, as `lab serve`; `off`: both at their nice throughout);
- `loop`: the whole build on the loop's own thread (a loop without a switcher: fast mode).

For each it prints one JSON line: per switch the robot, whether its world was compiled or came
from the cache, the periods the loop skipped from the command to its reply and the longest
interval between two ticks meanwhile (and the last of them, `swap_gap_ms`: the one that ends
with the tick that swapped the new robot in, which covers the build's end and the swap); over
the switches the median and the largest of those longest intervals, and the same of the
longest interval in windows as long as the median switch cut from the time outside switches
(`outside`: the machine's own noise in the same run; a switch that costs the loop nothing has
the same distribution); the longest tick's work, the longest pause of the garbage collector (it
stops every thread), the on-time fraction, the resident memory, and where the switch's thread
was after each gap over HOLDER_GAP_S (the C call that kept the GIL, or what it was doing while
the machine held the loop back). Each switcher
keeps the first robot's world first, as `lab serve` does, so that `compiled` is a robot's
first build and `cached` a switch back (lab/world/compiled.py, `KeptWorlds`).

A switch back copies the kept MjModel: `--copy native` (`lab._plant` without the GIL,
lab/world/compiled.py's `copied_model`: as `lab serve`), `binding` (MuJoCo's binding's copy,
which keeps the GIL), or both in turn (`native,binding,native,binding`: one run each, in that
order). The C heap maps its large blocks as `lab serve`'s does (lab/world/memory.py).

    .venv/bin/python benchmarks/bench_switch.py [--switches 8] [--every 1.5] [--robots solo12,bolt]
        [--modes worker,thread,loop] [--nices=-10,none,10] [--realtime on,off]
        [--loop-sched other|fifo] [--copy native,binding]
"""

import argparse
import copy
import json
import os
import statistics
import sys
import threading
import time
from pathlib import Path

from lab.protocol import RobotCommand
from lab.runtime.intake import Request
from lab.runtime.loop import LoopConfig, SimLoop
from lab.runtime.switch import Switcher
from lab.world.compiled import copied_model
from lab.world.memory import map_large_blocks
from lab.world.session import Session, SessionConfig

MODES = ("worker", "thread", "loop")
COPIES = {"native": copied_model, "binding": copy.copy}  # how a kept MjModel is copied
HOLDER_GAP_S = 4e-3  # a gap in a switch longer than this records where the switch's thread is


def switch_thread_frame() -> str:
    """Where the switch's thread is now (its three innermost Python frames): read by the loop
    as soon as it runs again after a long gap, that is where the thread gave the GIL back, so
    the C call it came out of is the one on the innermost line (or the machine preempted the
    loop, and the thread was anywhere: MuJoCo's compile, say, which runs without the GIL)."""
    thread = next((t for t in threading.enumerate() if t.name == "session-switch"), None)
    frame = None if thread is None else sys._current_frames().get(thread.ident)
    where = []
    while frame is not None and len(where) < 3:
        code = frame.f_code
        where.append(f"{Path(code.co_filename).name}:{frame.f_lineno} {code.co_name}")
        frame = frame.f_back
    return " < ".join(where) or "(no switch thread)"


def holders_summary(holders: list[tuple[float, str]]) -> list[dict]:
    """The places the switch's thread was after long gaps, by summed gap, largest first."""
    by_place: dict[str, list[float]] = {}
    for gap, place in holders:
        by_place.setdefault(place, []).append(gap * 1e3)
    rows = [
        {
            "where": where,
            "gaps": len(gaps),
            "sum_ms": round(sum(gaps), 1),
            "max_ms": round(max(gaps), 1),
        }
        for where, gaps in by_place.items()
    ]
    return sorted(rows, key=lambda row: -row["sum_ms"])[:8]


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


class Switching:
    """A transport that asks for a switch to the next robot every `every` s, `count` times,
    and times the loop: `receive` is called once a tick, so the interval between two calls is
    the interval between two ticks. A switch counts from the tick that sent it to the first
    tick after its reply (the loop counts what it skipped after the tick that swapped it in)."""

    def __init__(
        self, robots: list[str], every: float, count: int, stop: threading.Event, cache: bool
    ) -> None:
        """`cache`: whether a robot's world is kept after its first build (by the switcher)."""
        self.robots, self.every, self.count, self.stop = robots, every, count, stop
        self.cache = cache
        self.loop: SimLoop | None = None
        self.next_at = time.monotonic() + every
        self.switch: dict | None = None  # the switch under way, if any
        self.built: set[str] = set()  # robots whose world the switcher built
        self.errors: list[str] = []
        self.switches: list[dict] = []
        # (gap, where the switch's thread was when the loop ran again) for gaps in switches
        self.holders: list[tuple[float, str]] = []
        self.last_tick: float | None = None
        self.longest_outside = 0.0  # between two ticks while no switch is under way (s)
        # (tick, interval before it) outside switches, one list between two switches
        self.outside: list[list[tuple[float, float]]] = [[]]

    def receive(self) -> Request | None:
        now = time.monotonic()
        gap = 0.0 if self.last_tick is None else now - self.last_tick
        self.last_tick = now
        switch = self.switch
        if switch is None:
            self.longest_outside = max(self.longest_outside, gap)
            self.outside[-1].append((now, gap))
        else:
            switch["longest_gap"] = max(switch["longest_gap"], gap)
            if gap > HOLDER_GAP_S:
                self.holders.append((gap, switch_thread_frame()))
            if "reply_s" in switch:  # the first tick after the reply: the switch is over
                switch["swap_gap"] = gap
                self._finish(switch)
            return None
        if now < self.next_at:
            return None
        name = self.robots[(len(self.switches) + 1) % len(self.robots)]
        cold = name not in self.built or not self.cache
        self.built.add(name)
        self.switch = {"robot": name, "cold": cold, "sent": now, "longest_gap": 0.0}
        self.switch["skipped_before"] = self.loop.stats.skipped
        return Request("robot", {"name": name}, None, None, RobotCommand(name))

    def _finish(self, switch: dict) -> None:
        self.switches.append(
            {
                "robot": switch["robot"],
                "world": "compiled" if switch["cold"] else "cached",
                "reply_ms": round((switch["reply_s"] - switch["sent"]) * 1e3, 1),
                "skipped": self.loop.stats.skipped - switch["skipped_before"],
                "longest_gap_ms": round(switch["longest_gap"] * 1e3, 2),
                "swap_gap_ms": round(switch["swap_gap"] * 1e3, 2),
                "duration_s": self.last_tick - switch["sent"],
            }
        )
        self.switch = None
        self.outside.append([])
        self.next_at = self.last_tick + self.every
        if len(self.switches) == self.count:
            self.stop.set()

    def rejections(self) -> tuple[int, str, str]:
        return (0, "", "")

    def reply(self, request: Request, body: dict) -> None:
        if not body.get("ok"):
            self.errors.append(str(body))
        self.switch["reply_s"] = time.monotonic()

    def publish_telemetry(self, message: dict) -> None: ...
    def publish_state(self, message: dict) -> None: ...
    def publish_event(self, message: dict) -> None: ...


def windows_longest_ms(stretches: list[list[tuple[float, float]]], window_s: float) -> list[float]:
    """The longest interval between two ticks (ms) in each `window_s` window of each stretch of
    ticks ((time, interval before it)), windows laid end to end; a stretch's last, shorter
    window is dropped."""
    longest: list[float] = []
    for ticks in stretches:
        start, worst = None, 0.0
        for t, gap in ticks:
            if start is None:
                start = t
            elif t - start >= window_s:
                longest.append(worst * 1e3)
                start, worst = t, 0.0
            worst = max(worst, gap)
    return longest


def spread(values: list[float]) -> dict[str, float]:
    """Median and largest of `values`, and how many."""
    if not values:
        return {"n": 0}
    middle, largest = statistics.median(values), max(values)
    return {"p50": round(middle, 2), "max": round(largest, 2), "n": len(values)}


def run(
    mode: str,
    robots: list[str],
    every: float,
    count: int,
    nice: int | None,
    realtime: bool,
    sched: str = "other",
    copy_by: str = "native",
) -> dict:
    session = Session(SessionConfig(robot=robots[0]))
    stop = threading.Event()
    transport = Switching(robots, every, count, stop, cache=mode != "loop")
    switcher = None
    if mode != "loop":
        switcher = Switcher(worker=mode == "worker", nice=nice, realtime=realtime)
        switcher.kept.copy = COPIES[copy_by]
    if switcher is not None:
        switcher.keep(session.config)  # as `lab serve` does
        transport.built.add(robots[0])
    loop = SimLoop(session, transport, LoopConfig(sched=sched), switcher=switcher)
    transport.loop = loop
    before = rss_mb()
    loop.run(stop)
    if switcher is not None:
        switcher.close()
    stats, switches = loop.stats, transport.switches
    window = statistics.median(s.pop("duration_s") for s in switches)
    outside = windows_longest_ms(transport.outside, window)
    return {
        "built": mode,
        "loop_sched": loop.wanted_sched,
        "switch_thread_nice": nice,
        "copy": copy_by if mode == "thread" else None,  # the worker's worlds are loaded
        # switches run with the switch's thread and the loop's at SCHED_FIFO (lab/runtime/switch.py)
        "realtime_switches": 0 if switcher is None else switcher.realtime.rises,
        "load_average": [round(x, 1) for x in os.getloadavg()],
        "error": None if loop.error is None else repr(loop.error),
        "refused": transport.errors,
        "ticks": stats.ticks,
        "skipped": stats.skipped,
        "skipped_per_switch": round(sum(s["skipped"] for s in switches) / len(switches), 1),
        "longest_gap_ms": {
            "during_switches": round(max(s["longest_gap_ms"] for s in switches), 2),
            "outside_switches": round(transport.longest_outside * 1e3, 2),
        },
        # per switch, and per window of the median switch's length outside them
        "longest_gap_per_switch_ms": spread([s["longest_gap_ms"] for s in switches]),
        "swap_gap_ms": spread([s["swap_gap_ms"] for s in switches]),
        "longest_gap_per_window_outside_ms": {"window_s": round(window, 3), **spread(outside)},
        "longest_tick_work_ms": round(stats.work.max * 1e3, 2),
        "longest_gc_pause_ms": round(stats.gc.pauses.max * 1e3, 2),
        "on_time_fraction": round(stats.on_time / max(1, stats.ticks), 4),
        "rss_mb": {"before": round(before, 1), "after": round(rss_mb(), 1)},
        "switches": switches,
        f"where_the_switch_thread_was_after_gaps_over_{HOLDER_GAP_S * 1e3:g}_ms": holders_summary(
            transport.holders
        ),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--switches", type=int, default=8)
    parser.add_argument("--every", type=float, default=1.5, help="s between switches")
    parser.add_argument("--robots", default="solo12,bolt")
    parser.add_argument("--modes", default=",".join(MODES), help="of " + ", ".join(MODES))
    parser.add_argument(
        "--nices",
        default=str(LoopConfig.nice),
        help="the switch's thread's nice values, one run of each mode per value ('none': as the "
        "thread starts)",
    )
    parser.add_argument(
        "--realtime",
        default="on",
        help="on, off or both (on,off): the switch's thread and the loop's at SCHED_FIFO while a "
        "switch is under way, one run of each mode per value",
    )
    parser.add_argument(
        "--loop-sched",
        default="other",
        choices=("other", "fifo"),
        help="the loop's own policy (fifo: the windows outside switches at SCHED_FIFO too, as "
        "the loop is during a switch with --realtime on)",
    )
    parser.add_argument(
        "--copy",
        default="native",
        help="how a switch back copies the kept MjModel, one thread run per entry in order: "
        "native (lab._plant, without the GIL: lab serve's) or binding (MuJoCo's, keeping it)",
    )
    args = parser.parse_args()
    map_large_blocks()  # as lab serve does
    robots = args.robots.split(",")
    nices = [None if n == "none" else int(n) for n in args.nices.split(",")]
    if not set(values := args.realtime.split(",")) <= {"on", "off"}:
        parser.error(f"--realtime takes on, off or on,off, not {args.realtime!r}")
    realtimes = [value == "on" for value in values]
    copies = args.copy.split(",")
    if not set(copies) <= set(COPIES):
        parser.error(f"--copy takes native and binding, not {args.copy!r}")
    for mode in args.modes.split(","):
        if mode not in MODES:
            parser.error(f"unknown mode {mode!r} (modes: {', '.join(MODES)})")
        for nice in nices if mode != "loop" else [None]:
            for realtime in realtimes if mode != "loop" else [False]:
                for copy_by in copies if mode == "thread" else ["native"]:
                    result = run(
                        mode,
                        robots,
                        args.every,
                        args.switches,
                        nice,
                        realtime,
                        args.loop_sched,
                        copy_by,
                    )
                    print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
