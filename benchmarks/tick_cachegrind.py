"""The server tick's instructions, cache misses and heap allocations per tick, counted by valgrind's
callgrind with its cache simulation: repeatable whatever the machine's load (a benchmark, not a
test).

    .venv/bin/python benchmarks/tick_cachegrind.py [--robot anymal] [--trot] [--ticks 200]

A headless session on the server's native tick (one crossing, native_tick.py), settled
uninstrumented (bench_stages.py's `settled`), then `--ticks` ticks counted back to back (`warm`),
and `--ticks` each after writing EVICT_BYTES of other memory (`cold`: the simulated L1 data cache
and the unified L2 emptied of the tick's data and code, as the loop's sleep lets other processes
do; the L1 instruction cache keeps the tick's code, so its misses are a lower bound of a slept
tick's). Per tick, for the crossing alone (`ServerTick::tick`, collected by name) and for the whole
`Session.tick()` (everything between the phases' dumps, less the same evictions counted alone):
instructions (Ir), L1 data misses (D1mr + D1mw), last-level data misses (`LL data`, DLmr + DLmw:
with `cold`, about the 64-byte lines of data the tick touches), L1 instruction misses, last-level
code misses (`LL code`, ILmr: with `cold`, about the lines of code it runs), and the heap
allocations (calls of malloc, calloc, realloc, posix_memalign, aligned_alloc) and frees.

The simulated caches are this machine kind's (lscpu: 48 KB L1d, 64 KB L1i, 2 MB L2 per core).
"""

import argparse
import os
import re
import tempfile
from pathlib import Path

import numpy as np
from kernel_callgrind import callgrind, control

EVICT_BYTES = 8 << 20  # 4x the simulated L2: a write over it leaves none of the tick's data
CACHES = ("--I1=65536,8,64", "--D1=49152,12,64", "--LL=2097152,16,64")
CROSSING = "*ServerTick::tick*"
ALLOCATORS = {"malloc", "calloc", "realloc", "posix_memalign", "aligned_alloc"}
PHASES = ("warm", "cold", "evictions")


def body(robot: str, trot: bool, ticks: int) -> None:
    """What runs under valgrind: the three phases (PHASES), a dump after each."""
    from bench_stages import settled

    from lab.world.session import SessionConfig

    session = settled(SessionConfig(robot=robot), trot)
    other = np.zeros(EVICT_BYTES // 8)
    control("--instr=on")
    control("--zero")
    for _ in range(ticks):
        session.tick()
    control(f"--dump={PHASES[0]}")
    for _ in range(ticks):
        other += 1.0
        session.tick()
    control(f"--dump={PHASES[1]}")
    for _ in range(ticks):
        other += 1.0
    control(f"--dump={PHASES[2]}")
    report = session.tick_report()
    if report["tick"] != "native" or session.fell:
        raise SystemExit(f"tick_cachegrind: the native tick did not run to the end: {report}")


def parse(path: Path) -> tuple[dict[str, int], dict[str, dict[str, int]]]:
    """A callgrind dump's totals by event, and per function whose cost is self-counted in it
    (by name), its events."""
    text = path.read_text()
    events = re.search(r"^events: (.*)$", text, re.M).group(1).split()
    totals = re.search(r"^(?:summary|totals): (.*)$", text, re.M).group(1).split()
    names: dict[str, str] = {}

    def name_of(spec: str) -> str:
        found = re.match(r"\((\d+)\)(?: (.*))?", spec)
        if found is None:
            return spec
        if found.group(2):
            names[found.group(1)] = found.group(2)
        return names.get(found.group(1), spec)

    calls: dict[str, dict[str, int]] = {}
    callee = ""
    for line in text.splitlines():
        if line.startswith(("fn=", "cfn=")):
            resolved = name_of(line.split("=", 1)[1])
            if line.startswith("cfn="):
                callee = resolved
        elif line.startswith("calls=") and callee:
            count = int(line[6:].split()[0])
            calls.setdefault(callee, {"calls": 0})["calls"] += count
    return dict(zip(events, (int(t) for t in totals), strict=False)), calls


def run(robot: str, trot: bool, ticks: int, collect: str | None) -> dict[str, dict[str, int]]:
    """The three phases' totals (the crossing's only, when `collect` names it) and allocation
    counts, from one valgrind run."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        toggles = [f"--toggle-collect={collect}"] if collect else []
        options = ["--cache-sim=yes", *CACHES, *toggles]
        done = callgrind(__file__, [robot, "trot" if trot else "stand", str(ticks)], options, out)
        if done.returncode:
            raise SystemExit(f"tick_cachegrind: {robot} failed:\n{done.stderr[-2000:]}")
        result = {}
        triggers = {
            re.search(r"^desc: Trigger: .*?(\w+)$", p.read_text(), re.M).group(1): p
            for p in Path(tmp).iterdir()
            if p.name.startswith(out.name + ".")
        }
        for phase in PHASES:
            totals, calls = parse(triggers[phase])
            totals["allocations"] = sum(
                c["calls"] for name, c in calls.items() if name in ALLOCATORS
            )
            totals["frees"] = sum(c["calls"] for name, c in calls.items() if name == "free")
            result[phase] = totals
        return result


def per_tick(totals: dict[str, int], ticks: int) -> dict[str, float]:
    """Per tick: Ir, D1 misses, LL data misses, I1 misses, LL code misses, allocations, frees."""
    return {
        "Ir": totals.get("Ir", 0) / ticks,
        "D1 misses": (totals.get("D1mr", 0) + totals.get("D1mw", 0)) / ticks,
        "LL data": (totals.get("DLmr", 0) + totals.get("DLmw", 0)) / ticks,
        "I1 misses": totals.get("I1mr", 0) / ticks,
        "LL code": totals.get("ILmr", 0) / ticks,
        "allocations": totals["allocations"] / ticks,
        "frees": totals["frees"] / ticks,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="anymal")
    parser.add_argument("--trot", action="store_true", help="trot at 0.5 m/s instead of standing")
    parser.add_argument("--ticks", type=int, default=200)
    parser.add_argument("--body", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.body:
        robot, doing, ticks = args.body
        body(robot, doing == "trot", int(ticks))
        return
    doing = "trotting" if args.trot else "standing"
    print(f"load average {os.getloadavg()[0]:.1f}; {args.robot} {doing}, {args.ticks} ticks")
    crossing = run(args.robot, args.trot, args.ticks, CROSSING)
    whole = run(args.robot, args.trot, args.ticks, None)
    # the whole cold tick: the cold phase less the evictions counted alone
    cold_whole = {k: whole["cold"][k] - whole["evictions"][k] for k in whole["cold"]}
    rows = {
        "crossing, warm": per_tick(crossing["warm"], args.ticks),
        "crossing, cold": per_tick(crossing["cold"], args.ticks),
        "Session.tick, warm": per_tick(whole["warm"], args.ticks),
        "Session.tick, cold": per_tick(cold_whole, args.ticks),
    }
    columns = next(iter(rows.values())).keys()
    print(f"  {'per tick':20s}" + "".join(f"{c:>13s}" for c in columns))
    for name, row in rows.items():
        print(f"  {name:20s}" + "".join(f"{row[c]:13,.1f}" for c in columns))


if __name__ == "__main__":
    main()
