"""The resident memory's floor over robot switches (not a test): tests/runtime/test_switch.py's
measurement (the lowest RSS over switches 11-30 and over the last 20; Solo12 switched to Solo12,
built on the switch's thread, swapped in, the old parts freed there) under each C heap setting
and copy of the kept MuJoCo model, each run in a fresh process, two at a time (as the suite's
two xdist workers).

- `--heaps`: `1mib` fixes glibc's mmap threshold at 1 MiB as `lab serve` does
  (lab/world/memory.py `map_large_blocks`, before the lab is imported), `dynamic` leaves
  glibc's default (the threshold raised to each large block freed);
- `--copies`: `native` (`lab._plant`, without the GIL: `lab serve`'s) or `binding` (MuJoCo's);
- `--trim off`: the switch's thread does not call `malloc_trim` after freeing the old parts;
- `--collect-every N`: `gc.collect()` after every Nth switch too (0: only before each sample of
  the two windows, as the test).

One JSON line per run: the setting, both floors (MB) and their ratio (the test's bound: 1.05),
and the C heap (`heap_usage`: in use, and free but kept) after the last switch.

    .venv/bin/python benchmarks/bench_switch_memory.py [--runs 10] [--switches 200]
        [--heaps 1mib,dynamic] [--copies native,binding] [--trim on,off] [--collect-every 0]
"""

import argparse
import copy
import gc
import itertools
import json
import os
import subprocess
import sys
import time
from pathlib import Path

WINDOW = 20  # switches whose lowest RSS stands for each end of the run (as the test)
ROBOT = "solo12"


def rss_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS")


def one_run(switches: int, heap: str, copy_by: str, trim: bool, collect_every: int) -> dict:
    """The two floors of one run in this process (a fresh one: see `main`)."""
    from lab.world.memory import heap_usage, map_large_blocks

    if heap == "1mib" and not map_large_blocks():
        raise RuntimeError("this C library has no mallopt")
    import lab.runtime.switch as switch_module
    from lab.protocol import RobotCommand
    from lab.runtime.intake import Request
    from lab.world.compiled import copied_model
    from lab.world.session import Session, SessionConfig

    if not trim:
        switch_module.release_free_memory = lambda: True
    session = Session(SessionConfig(robot=ROBOT))
    switcher = switch_module.Switcher()
    switcher.kept.copy = copied_model if copy_by == "native" else copy.copy
    early: list[float] = []
    late: list[float] = []
    command = RobotCommand(ROBOT)
    for done in range(1, switches + 1):
        request = Request("robot", {"name": ROBOT}, None, None, command)
        switcher.start(request, session.switch_config(command))
        while (built := switcher.finished()) is None:
            time.sleep(0.005)
        if built.parts is None:
            raise RuntimeError(built.error)
        switcher.discard(session.install(built.parts))
        for _ in range(5):
            session.tick()
        window = early if 10 < done <= 10 + WINDOW else late if done > switches - WINDOW else None
        if window is not None or (collect_every and done % collect_every == 0):
            gc.collect()
        if window is not None:
            window.append(rss_mb())
    switcher.close()
    return {
        "heap": heap,
        "copy": copy_by,
        "trim": trim,
        "collect_every": collect_every,
        "switches": switches,
        "floor_early_mb": round(min(early), 1),
        "floor_late_mb": round(min(late), 1),
        "ratio": round(min(late) / min(early), 4),
        "heap_after_mb": heap_usage(),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=10, help="per setting, two at a time")
    parser.add_argument("--switches", type=int, default=200)
    parser.add_argument("--heaps", default="1mib,dynamic")
    parser.add_argument("--copies", default="native,binding")
    parser.add_argument("--trim", default="on")
    parser.add_argument("--collect-every", type=int, default=0)
    parser.add_argument("--one", help=argparse.SUPPRESS)  # a child's run: heap,copy,trim
    args = parser.parse_args()
    if args.switches < 10 + 2 * WINDOW or args.runs < 1 or args.collect_every < 0:
        parser.error(f"--switches at least {10 + 2 * WINDOW}, --runs at least 1")
    if args.one is not None:
        heap, copy_by, trim = args.one.split(",")
        run = one_run(args.switches, heap, copy_by, trim == "on", args.collect_every)
        print(json.dumps(run), flush=True)
        return 0
    settings = list(
        itertools.product(args.heaps.split(","), args.copies.split(","), args.trim.split(","))
    )
    for heap, copy_by, trim in settings:
        if heap not in ("1mib", "dynamic") or copy_by not in ("native", "binding"):
            parser.error(f"unknown heap or copy: {heap}, {copy_by}")
        if trim not in ("on", "off"):
            parser.error(f"--trim takes on, off or on,off, not {trim!r}")
    child = [sys.executable, __file__, "--switches", str(args.switches)]
    child += ["--collect-every", str(args.collect_every)]
    for setting in settings:
        for pair in range(0, args.runs, 2):
            runs = [
                subprocess.Popen([*child, "--one", ",".join(setting)], stdout=subprocess.PIPE)
                for _ in range(min(2, args.runs - pair))
            ]
            for process in runs:
                out, _ = process.communicate()
                if process.returncode != 0:
                    print(f"a run of {setting} failed ({process.returncode})", file=sys.stderr)
                    return 1
                result = json.loads(out)
                result["load_average"] = [round(x, 1) for x in os.getloadavg()]
                print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
