"""`lab bench`: controller tick and headless real-time factor per robot, method and kernel.

A benchmark, not a test: it prints medians and p99 for a person to read and record in
docs/performance.md. Each run stands the robot for a while, pushes it sideways (so that the QPs
have work to do), and times every tick; the Python and the native kernel run back to back on
the same run, and the table gives native/python of the medians. `tick` is what the session pays
per control period (model update, behaviour, controller); `solve` is the controller alone
(`controller.solve()`, the native kernel's whole tick from q, v and references), repeated at
the final state. `kernel` is the native kernel's own model update + rows + solve per tick, timed
inside it (no Python around it). `--solvers daqp clarabel` times both QP backends; the native
kernel solves with DAQP only, so a Clarabel run asked of it runs on the Python kernel and its
row says so (kernel python, `note`).
"""

import argparse
import json
import time

import numpy as np

from lab.controller.native import NOT_BUILT
from lab.server.session import Session, SessionConfig

ROBOTS = ("anymal", "hyq", "solo12", "talos")
METHODS = ("cascade", "weighted")
KERNELS = ("python", "native")
SOLVERS = ("daqp", "clarabel")
PUSH_FRACTION_OF_WEIGHT = 0.1  # lateral push on the base for 0.1 s, as a fraction of the weight
SOLVE_REPEATS = 500


def _stats(us: np.ndarray) -> dict[str, float]:
    us = us[np.isfinite(us)]  # ticks the kernel did not time (Python, a fall) are left out
    return {"p50": float(np.median(us)), "p99": float(np.percentile(us, 99))}


def bench_one(
    robot: str, method: str, seconds: float, kernel: str = "python", solver: str = "daqp"
) -> dict:
    """One run: the ticks of `seconds` of standing with a push, then the solve repeated; the row
    names what ran (kernel, solver) and the note when it is not what was asked."""
    session = Session(SessionConfig(robot=robot, method=method, kernel=kernel, solver=solver))
    weight = session.model.mass * 9.81
    ticks = round(seconds / session.config.timestep)
    control_us = np.zeros(ticks)
    kernel_us = np.full(ticks, np.nan)  # the native kernel's update + solve, timed inside it
    wall_start = time.perf_counter()
    for i in range(ticks):
        if i == ticks // 2:
            force = [0.0, PUSH_FRACTION_OF_WEIGHT * weight, 0.0]
            push = {"body": session.robot.base_link, "force": force, "duration": 0.1}
            session.handle("push", push)
        session.tick()
        control_us[i] = session.control_us
        inside = getattr(session.controller, "kernel_seconds", None)
        if inside is not None:
            kernel_us[i] = sum(inside) * 1e6
    wall = time.perf_counter() - wall_start
    solve_us = np.zeros(SOLVE_REPEATS)
    controller = session.controller
    for i in range(SOLVE_REPEATS):
        start = time.perf_counter()
        controller.solve()
        solve_us[i] = (time.perf_counter() - start) * 1e6
    return {
        "robot": robot,
        "method": method,
        "kernel": controller.ran.kernel,
        "solver": controller.ran.solver,
        "note": controller.note,
        "ticks": ticks,
        "controller_us": _stats(control_us),
        "kernel_us": _stats(kernel_us) if np.isfinite(kernel_us).any() else None,
        "solve_us": _stats(solve_us),
        "realtime_factor": session.time / wall,
        "fell": session.fell,
        "qp_failures": session.qp_failures,
    }


def bench_main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="lab bench", description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated seconds per run")
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=ROBOTS)
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    parser.add_argument("--kernels", nargs="+", default=list(KERNELS), choices=KERNELS)
    parser.add_argument("--solvers", nargs="+", default=["daqp"], choices=SOLVERS)
    args = parser.parse_args(argv)
    if "native" in args.kernels and NOT_BUILT:
        print(f"lab bench: {NOT_BUILT}: timing the Python kernel only")
        args.kernels = ["python"]
    rows = [
        bench_one(r, m, args.seconds, k, s)
        for r in args.robots
        for m in args.methods
        for s in args.solvers
        for k in args.kernels
    ]
    if args.json:
        print(json.dumps({"controller_tick": rows}))
        return 0
    print(
        f"{'robot':8} {'method':9} {'solver':8} {'kernel':7} {'tick p50 µs':>12} "
        f"{'tick p99 µs':>12} "
        f"{'solve p50 µs':>13} {'solve p99 µs':>13} {'kernel p50/p99 µs':>18} {'RTF':>6}  fell"
    )
    for row in rows:
        tick, solve, inside = row["controller_us"], row["solve_us"], row["kernel_us"]
        kernel = f"{inside['p50']:.0f} / {inside['p99']:.0f}" if inside else "-"
        print(
            f"{row['robot']:8} {row['method']:9} {row['solver']:8} {row['kernel']:7} "
            f"{tick['p50']:12.0f} "
            f"{tick['p99']:12.0f} {solve['p50']:13.1f} {solve['p99']:13.1f} {kernel:>18} "
            f"{row['realtime_factor']:6.2f}  {row['fell']}"
        )
    for row in rows:
        if row["note"]:
            print(f"{row['robot']} {row['method']} {row['solver']}: {row['note']}")
    pairs = {(r["robot"], r["method"], r["solver"], r["kernel"]): r for r in rows}
    for robot in args.robots:
        for method in args.methods:
            python, native = (
                pairs.get((robot, method, "daqp", "python")),
                pairs.get((robot, method, "daqp", "native")),
            )
            if python and native:
                print(
                    f"native/python {robot:8} {method:9} tick "
                    f"{native['controller_us']['p50'] / python['controller_us']['p50']:.2f}  solve "
                    f"{native['solve_us']['p50'] / python['solve_us']['p50']:.2f}"
                )
    return 0
