"""`lab bench`: controller tick and headless real-time factor per robot, gait, method and kernel.

A benchmark, not a test: it prints medians and p99 for a person to read and record in
docs/performance.md. Each run stands the robot for a while, pushes it sideways (so that the QPs
have work to do), and times every tick. `--gaits` adds other situations: `trot`, a quadruped
trotting at 0.3 m/s from the start (its walking stack, Raiola S3, comes with the gait), pushed the
same way; `single`, Talos (its arms locked or free) or G1 shifting onto its left sole and lifting
the right (Herzog 2016 §5.4: Table 4, LQR), pushed as there (150 N for 35 ms); `biped_step`, Kim's
stepping stack on Bolt, walking at 0.2 m/s while turning at 0.3 rad/s, its footsteps replanned
every tick from 80 % of each lift. A gait that brings its stack preset keeps the benched method.
The Python and the native kernel run back to back on the same run, and the table gives
native/python of the medians. `tick` is what the session pays per control period (model update,
behaviour, controller); `solve` is the controller alone (`controller.solve()`, the native kernel's
whole tick from q, v and references), repeated at the final state. `kernel` is the native kernel's
own model update + rows + solve per tick, timed inside it (no Python around it), and the JSON gives
the median of each of those stages (`kernel_stages_us`). `--solvers daqp clarabel` times both QP
backends; the native kernel solves with DAQP only, so a Clarabel run asked of it runs on the Python
kernel and its row says so (kernel python, `note`). Every row names what ran (`controller.ran`:
kernel, method, solver); a robot, gait and method asked that do not go together (trot on a biped)
get no row, and stderr says why.
`--cpu-time` takes the real-time factor on the loop thread's CPU time (a shared machine's
descheduling left out; the JSON's `realtime_clock` says which clock).
"""

import argparse
import json
import sys
import time
from dataclasses import dataclass

import numpy as np

from lab.controller.native import NOT_BUILT
from lab.description import ROBOT_NAMES
from lab.world.memory import long_lived_objects_frozen
from lab.world.session import Session, SessionConfig

ROBOTS = ("anymal", "hyq", "solo12", "talos", "bolt")  # the default rows; --robots takes any
METHODS = ("cascade", "weighted", "nullspace", "wbosc")
# wbosc is Kim 2016's method for point-foot bipeds: it enforces no inequality, so it stands
# Bolt and no other robot of the lab.
WBOSC_ROBOTS = ("bolt",)
KERNELS = ("python", "native")
SOLVERS = ("daqp", "clarabel")
TROT_SPEED = 0.3  # m/s forward
STEERING = {"vx": 0.2, "vy": 0.0, "yaw_rate": 0.3}  # the velocity command of biped_step's rows
PUSH_FRACTION_OF_WEIGHT = 0.1  # lateral push on the base for 0.1 s, as a fraction of the weight
# Bolt on its foot line under wbosc (which enforces no inequality) falls 0.33 s after a push of
# 0.1 of its weight, on either kernel; it takes 0.05.
PUSH_FRACTION_OF_WEIGHT_OF = {"bolt": 0.05}
HERZOG_PUSH = (150.0, 0.035)  # N, s: a single-support push of Herzog 2016 §5.4
SOLVE_REPEATS = 500
# The native kernel's stages, as Kernel.seconds times them (cpp/controller.cpp)
KERNEL_STAGES = ("update", "rows", "method")


@dataclass(frozen=True)
class Gait:
    """A situation to time: the robots it applies to (None: every robot) and the commands that
    set it up."""

    robots: tuple[str, ...] | None
    commands: tuple[tuple[str, dict], ...] = ()


GAITS = {
    "stand": Gait(None),
    "trot": Gait(
        ("anymal", "hyq", "solo12", "go2", "a1", "b1"),
        (("gait", {"name": "trot"}), ("velocity", {"vx": TROT_SPEED, "vy": 0.0, "yaw_rate": 0.0})),
    ),
    "single": Gait(
        ("talos", "talos_arms", "g1"), (("momentum", {"mode": "lqr"}), ("stance", {"side": "left"}))
    ),
    "biped_step": Gait(("bolt",), (("gait", {"name": "biped_step"}), ("velocity", STEERING))),
}


def _why_not(robot: str, method: str, gait: str) -> str:
    """Why `robot` has no `gait` / `method` row ('' when it has one)."""
    robots = GAITS[gait].robots
    if robots is not None and robot not in robots:
        return f"gait {gait!r} is timed on {', '.join(robots)} only"
    if method == "wbosc" and robot not in WBOSC_ROBOTS:
        return f"wbosc is timed on {', '.join(WBOSC_ROBOTS)} only"
    return ""


def _stats(us: np.ndarray) -> dict[str, float]:
    us = us[np.isfinite(us)]  # ticks the kernel did not time (Python, a fall) are left out
    return {"p50": float(np.median(us)), "p99": float(np.percentile(us, 99))}


def bench_one(
    robot: str,
    method: str,
    seconds: float,
    kernel: str = "python",
    gait: str = "stand",
    solver: str = "daqp",
    cpu_time: bool = False,
) -> dict:
    """One run: the ticks of `seconds` of `gait` with a push, then the solve repeated; the row
    names what ran (kernel, method, solver) and the note when it is not what was asked.
    `cpu_time`: the real-time factor on this thread's CPU time instead of the wall clock."""
    session = Session(SessionConfig(robot=robot, method=method, kernel=kernel, solver=solver))
    for verb, payload in GAITS[gait].commands:
        reply = session.handle(verb, payload)
        if not reply["ok"]:
            raise ValueError(f"lab bench: {robot} {gait}: {verb}: {reply['error']}")
        if "preset" in reply:  # the gait brought its stack: the benched method replaces its own
            session.handle("hierarchy", {"method": method})
    force, duration = PUSH_FRACTION_OF_WEIGHT_OF.get(robot, PUSH_FRACTION_OF_WEIGHT), 0.1
    force *= session.model.mass * 9.81
    if gait == "single":
        force, duration = HERZOG_PUSH
    ticks = round(seconds / session.config.timestep)
    control_us = np.zeros(ticks)
    # the native kernel's stages (update, rows, method and torques), timed inside it
    stages_us = np.full((ticks, len(KERNEL_STAGES)), np.nan)
    capped = 0  # nullspace: ticks whose active-set search stopped at its cap
    # as `lab run` and the server's loop tick (perf: gc_collect_main was ~1 % of Talos's
    # standing tick with the imports' objects scanned)
    with long_lived_objects_frozen():
        clock = time.thread_time if cpu_time else time.perf_counter
        wall_start = clock()
        for i in range(ticks):
            if i == ticks // 2:
                push = {"body": session.robot.base_link, "force": [0.0, force, 0.0]}
                session.handle("push", {**push, "duration": duration})
            session.tick()
            # from the status, not `session.solution`: a native tick builds its HierarchySolution
            # only when read (telemetry reads it at 100 Hz); read here every tick it cost 8-10 µs
            # of CPU a tick under the cascade and 29-40 under nullspace (its active sets become
            # arrays), the benchmark's own cost counted in the session's real-time factor
            capped += session.status.status == "capped"
            control_us[i] = session.control_us
            inside = session.controller.kernel_seconds
            if inside is not None:
                stages_us[i] = inside
        wall = clock() - wall_start
    stages_us *= 1e6
    kernel_us = stages_us.sum(axis=1)
    solve_us = np.zeros(SOLVE_REPEATS)
    controller = session.controller
    for i in range(SOLVE_REPEATS):
        start = time.perf_counter()
        controller.solve()
        solve_us[i] = (time.perf_counter() - start) * 1e6
    return {
        "robot": robot,
        "nv": session.model.nv,
        "gait": gait,
        "method": controller.ran.method,
        "kernel": controller.ran.kernel,
        "solver": controller.ran.solver,
        "note": controller.note,
        "ticks": ticks,
        "controller_us": _stats(control_us),
        "kernel_us": _stats(kernel_us) if np.isfinite(kernel_us).any() else None,
        "kernel_stages_us": (
            {stage: _stats(stages_us[:, k])["p50"] for k, stage in enumerate(KERNEL_STAGES)}
            if np.isfinite(kernel_us).any()
            else None
        ),
        "solve_us": _stats(solve_us),
        "realtime_factor": session.time / wall,
        "realtime_clock": "thread CPU" if cpu_time else "wall",
        "fell": session.fell,
        "capped_ticks": capped,
        "qp_failures": session.qp_failures,
    }


def bench_main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="lab bench", description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated seconds per run")
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=ROBOT_NAMES)
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--kernels", nargs="+", default=list(KERNELS), choices=KERNELS)
    parser.add_argument("--solvers", nargs="+", default=["daqp"], choices=SOLVERS)
    parser.add_argument(
        "--gaits",
        nargs="+",
        default=list(GAITS),
        choices=list(GAITS),
        help="stand: every robot; trot: the quadrupeds; single: Talos (arms too) or G1 on one "
        "sole; "
        "biped_step: Bolt walking",
    )
    parser.add_argument(
        "--cpu-time",
        action="store_true",
        help="real-time factor on the loop thread's CPU time, not the wall clock (a shared "
        "machine: descheduled time does not count; caches shared with other work still do)",
    )
    args = parser.parse_args(argv)
    if "native" in args.kernels and NOT_BUILT:
        print(f"lab bench: {NOT_BUILT}: timing the Python kernel only")
        args.kernels = ["python"]
    combinations = [(r, m, g) for r in args.robots for g in args.gaits for m in args.methods]
    runs = [c for c in combinations if not _why_not(*c)]
    skipped = {_why_not(*c) for c in combinations} - {""}
    for why in sorted(skipped):  # said, never silently left out
        print(f"lab bench: no row where {why}", file=sys.stderr)
    if not runs:
        print(
            "lab bench: nothing to time: no robot, gait and method asked go together",
            file=sys.stderr,
        )
        return 2
    asked = [(r, g, m, s, k) for r, m, g in runs for s in args.solvers for k in args.kernels]
    rows = [bench_one(r, m, args.seconds, k, g, s, args.cpu_time) for r, g, m, s, k in asked]
    if args.json:
        print(json.dumps({"controller_tick": rows}))
        return 0
    print(
        f"{'robot':10} {'gait':10} {'method':9} {'solver':8} {'kernel':7} {'tick p50 µs':>12} "
        f"{'tick p99 µs':>12} {'solve p50 µs':>13} {'solve p99 µs':>13} "
        f"{'kernel p50/p99 µs':>18} {'RTF':>6}  fell  capped"
    )
    if args.cpu_time:
        print("(RTF: simulated time over the loop thread's CPU time, not the wall clock)")
    for row in rows:
        tick, solve, inside = row["controller_us"], row["solve_us"], row["kernel_us"]
        kernel = f"{inside['p50']:.0f} / {inside['p99']:.0f}" if inside else "-"
        print(
            f"{row['robot']:10} {row['gait']:10} {row['method']:9} {row['solver']:8} "
            f"{row['kernel']:7} "
            f"{tick['p50']:12.0f} "
            f"{tick['p99']:12.0f} {solve['p50']:13.1f} {solve['p99']:13.1f} {kernel:>18} "
            f"{row['realtime_factor']:6.2f}  {row['fell']!s:5} {row['capped_ticks']}"
        )
    for row in rows:
        if row["note"]:
            print(f"{row['robot']} {row['gait']} {row['method']} {row['solver']}: {row['note']}")
    pairs = dict(zip(asked, rows, strict=True))  # by what was asked: a row says what ran
    for robot, method, gait in runs:
        python, native = (
            pairs.get((robot, gait, method, "daqp", "python")),
            pairs.get((robot, gait, method, "daqp", "native")),
        )
        if python and native:
            print(
                f"native/python {robot:10} {gait:10} {method:9} tick "
                f"{native['controller_us']['p50'] / python['controller_us']['p50']:.2f}  solve "
                f"{native['solve_us']['p50'] / python['solve_us']['p50']:.2f}"
            )
    return 0
