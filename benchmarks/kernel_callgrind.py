"""The native kernel's instructions per tick, counted by valgrind's callgrind: repeatable whatever
the machine's load, so before/after comparisons of a C++ change hold on a shared machine.

    .venv/bin/python benchmarks/kernel_callgrind.py [--robots g1 talos_arms anymal] [--ticks 200]
    .venv/bin/python benchmarks/kernel_callgrind.py --single [--robots g1 talos_arms] [--ticks 500]
    .venv/bin/python benchmarks/kernel_callgrind.py --tsid [--robots anymal talos]
    .venv/bin/python benchmarks/kernel_callgrind.py --tsid --theirs [--robots anymal talos]

Per robot and method: a headless session standing on the native kernel for `--ticks` ticks, run
under `valgrind --tool=callgrind` with collection on only inside `Kernel::update` and
`Kernel::solve` (the model update, then the rows, the hierarchy method and τ); prints the
instructions per tick and the heaviest functions (inclusive) of that count. The session's first
WARMUP ticks settle the robot onto its feet, uninstrumented and not counted.

`--single`: `lab bench --gaits single`'s run instead (the LQR momentum law, the left sole, the
push at 1 s), counted from SINGLE_FROM on: the ticks while the right sole's force bound ramps to
zero, where `nullspace` makes its release trials (docs/performance.md, "Round 18: where the
free-arm rows' mean tick goes").

`--tsid`: benchmarks/bench_tsid.py's side of the comparison instead, whole: its `weighted`
controller's `compute(q, v)` cycling through its recorded states with their references, as its
timing loop calls it, every instruction counted (Python, the crossing, the references, the
outcome and the kernel): the part of ours/TSID that the load cannot move.

`--tsid --theirs`: TSID's side of the same comparison, counted the same way: bench_tsid's
`TsidProblem.tick` (three setReference, computeProblemData, solve, getActuatorForces) on the same
recorded states, in bench_tsid's TSID venv (made on first use, as bench_tsid makes it).
"""

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType

COLLECT = ("lab::Kernel::update*", "lab::Kernel::solve()*")
WARMUP = 100  # ticks before the count: the robot settles onto its feet
SINGLE_FROM = 1000  # --single: the push's tick; the sole unloads from here to ~1500


def control(*args: str) -> None:
    """A callgrind_control request to this process, given time to land (callgrind reads it on
    its next poll, which this sleep waits for)."""
    subprocess.run(["callgrind_control", *args, str(os.getpid())], check=True, capture_output=True)
    time.sleep(1.0)


def callgrind(
    script: str, body: list[str], options: list[str], out: Path, python: str = sys.executable
) -> subprocess.CompletedProcess[str]:
    """`script --body *body` run under callgrind with instrumentation off until the body's
    `control("--instr=on")`, its profile written to `out` (and `out`.N for each dump)."""
    command = [
        "valgrind",
        "--tool=callgrind",
        "--instr-atstart=no",
        *options,
        f"--callgrind-out-file={out}",
        python,
        script,
        "--body",
        *body,
    ]
    return subprocess.run(command, capture_output=True, text=True)


def stand(robot: str, method: str, ticks: int, single: bool = False) -> None:
    """The body that runs under valgrind: `ticks` standing ticks of a native session, or with
    `single` those from SINGLE_FROM on of `lab bench --gaits single`'s run."""
    from lab.experiments.bench import GAITS, HERZOG_PUSH
    from lab.world.session import Session, SessionConfig

    session = Session(SessionConfig(robot=robot, method=method, kernel="native"))
    if single:
        for verb, payload in GAITS["single"].commands:
            if "preset" in session.handle(verb, payload):  # as lab bench: the method benched
                session.handle("hierarchy", {"method": method})
    for _ in range(SINGLE_FROM if single else WARMUP):
        session.tick()
    if single:
        force, duration = HERZOG_PUSH
        push = {"body": session.robot.base_link, "force": [0.0, force, 0.0]}
        session.handle("push", {**push, "duration": duration})
    # Instrumentation on from here only (valgrind runs the imports and set-up uninstrumented,
    # several times faster).
    control("--instr=on")
    for _ in range(ticks):
        session.tick()
    if session.controller.kernel_ran != "native":
        raise SystemExit(f"kernel_callgrind: {robot} {method} did not run native")
    if session.fell:
        raise SystemExit(f"kernel_callgrind: {robot} fell")


def _bench_tsid() -> ModuleType:
    """benchmarks/bench_tsid.py, imported from beside this file."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_tsid

    return bench_tsid


def tsid_path(spec: str, ticks: int) -> None:
    """The body that runs under valgrind in the TSID venv for --tsid --theirs: TSID's timing
    loop (bench_tsid's TsidProblem.tick over the states of `spec`), counted whole."""
    bench_tsid = _bench_tsid()
    problem = bench_tsid.TsidProblem(json.loads(Path(spec).read_text()), "SolverHQuadProgFast")
    n = len(problem.states)
    for i in range(WARMUP):
        problem.tick(i % n)
    control("--instr=on")
    for i in range(ticks):
        problem.tick(i % n)
    control("--instr=off")


def tsid_spec(robot: str, out: Path) -> None:
    """bench_tsid's problem for `robot` (its recorded states, gains and contacts), as its worker
    reads it, written to `out`."""
    bench_tsid = _bench_tsid()
    recorded = bench_tsid.record_states(robot, 4, 4)
    controller = bench_tsid.our_controller(recorded["session"], robot)
    problem = bench_tsid.problem_for_tsid(recorded["session"], controller, recorded["states"])
    out.write_text(json.dumps(problem))


def compute_path(robot: str, ticks: int) -> None:
    """The body that runs under valgrind for --tsid: bench_tsid's timing loop of `ticks` calls,
    every instruction between the two requests counted."""
    bench_tsid = _bench_tsid()
    recorded = bench_tsid.record_states(robot, 4, 4)
    controller = bench_tsid.our_controller(recorded["session"], robot)
    states = recorded["states"]

    def run(count: int) -> None:  # what bench_tsid's time_ours times, without its clock
        for i in range(count):
            q, v, refs = states[i % len(states)]
            controller.references = refs
            controller.compute(q, v)

    run(WARMUP)
    control("--instr=on")
    run(ticks)
    control("--instr=off")
    if controller.kernel_ran != "native":
        raise SystemExit(f"kernel_callgrind: {robot} did not run native")


def count(
    robot: str, method: str, ticks: int, top: int, single: bool = False
) -> tuple[int, list[str]]:
    """Instructions per tick inside the kernel (method "tsid": bench_tsid's compute path whole;
    "tsid-theirs": TSID's side of it whole; `single`: the unload ticks of `--single`), and the
    `top` heaviest inclusive lines."""
    collect = () if method.startswith("tsid") else COLLECT
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        toggles = [f"--toggle-collect={pattern}" for pattern in collect]
        body = [robot, method, str(ticks), "single" if single else "stand"]
        python = sys.executable
        if method == "tsid-theirs":
            bench_tsid = _bench_tsid()
            python = str(bench_tsid.ensure_tsid_venv(bench_tsid.DEFAULT_VENV, False))
            spec = Path(tmp) / f"{robot}.json"
            tsid_spec(robot, spec)
            body = [str(spec), method, str(ticks), "stand"]
        run = callgrind(__file__, body, toggles, out, python)
        if run.returncode:
            raise SystemExit(f"kernel_callgrind: {robot} {method} failed:\n{run.stderr[-2000:]}")
        report = subprocess.run(
            ["callgrind_annotate", "--inclusive=yes", str(out)],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
    total = int(
        re.search(r"([\d,]+) \(100\.0%\)\s+PROGRAM TOTALS", report).group(1).replace(",", "")
    )
    lines = [line for line in report.splitlines() if re.match(r"\s*[\d,]+ \(", line)]
    return total // ticks, lines[1 : top + 1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=["g1", "talos_arms", "anymal"])
    parser.add_argument("--methods", nargs="+", default=["cascade"])
    parser.add_argument("--ticks", type=int, default=200)
    parser.add_argument("--top", type=int, default=25, help="heaviest functions to print")
    parser.add_argument(
        "--tsid", action="store_true", help="bench_tsid's compute(q, v) path whole (module doc)"
    )
    parser.add_argument(
        "--theirs", action="store_true", help="with --tsid: TSID's side instead (module doc)"
    )
    parser.add_argument(
        "--single",
        action="store_true",
        help="the unload ticks of lab bench's single-support run, not standing (module doc)",
    )
    parser.add_argument("--body", nargs=4, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.body:
        robot, method, ticks, mode = args.body
        if method == "tsid":
            compute_path(robot, int(ticks))
        elif method == "tsid-theirs":
            tsid_path(robot, int(ticks))  # `robot`: the problem's spec file
        else:
            stand(robot, method, int(ticks), single=mode == "single")
        return
    what = f"from tick {SINGLE_FROM} of lab bench's single run" if args.single else "standing"
    print(f"load average {os.getloadavg()[0]:.1f}; {args.ticks} ticks each, {what}")
    for robot in args.robots:
        tsid = ["tsid-theirs" if args.theirs else "tsid"]
        for method in tsid if args.tsid else args.methods:
            per_tick, lines = count(robot, method, args.ticks, args.top, args.single)
            print(f"{robot} {method}: {per_tick:,} instructions per tick")
            print("\n".join(lines))


if __name__ == "__main__":
    main()
