"""`lab bench`: controller tick and headless real-time factor per robot and hierarchy method.

A benchmark, not a test: it prints medians and p99 for a person to read and record in
docs/performance.md. Each run stands the robot for a while, pushes it sideways (so that the QPs
have work to do), and times every tick.
"""

import argparse
import json
import time

import numpy as np

from lab.server.session import Session, SessionConfig

ROBOTS = ("anymal", "hyq", "solo12", "talos")
METHODS = ("cascade", "weighted")
PUSH_FRACTION_OF_WEIGHT = 0.1  # lateral push on the base for 0.1 s, as a fraction of the weight


def bench_one(robot: str, method: str, seconds: float) -> dict:
    session = Session(SessionConfig(robot=robot, hierarchy=method))
    weight = session.model.mass * 9.81
    ticks = round(seconds / session.config.timestep)
    control_us = np.zeros(ticks)
    wall_start = time.perf_counter()
    for i in range(ticks):
        if i == ticks // 2:
            force = [0.0, PUSH_FRACTION_OF_WEIGHT * weight, 0.0]
            push = {"body": session.robot.base_link, "force": force, "duration": 0.1}
            session.handle("push", push)
        session.tick()
        control_us[i] = session.control_us
    wall = time.perf_counter() - wall_start
    return {
        "robot": robot,
        "method": method,
        "ticks": ticks,
        "controller_us": {
            "p50": float(np.median(control_us)),
            "p99": float(np.percentile(control_us, 99)),
        },
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
    args = parser.parse_args(argv)
    rows = [bench_one(r, m, args.seconds) for r in args.robots for m in args.methods]
    if args.json:
        print(json.dumps({"controller_tick": rows}))
        return 0
    print(f"{'robot':8} {'method':9} {'tick p50 µs':>12} {'tick p99 µs':>12} {'RTF':>6}  fell")
    for row in rows:
        tick = row["controller_us"]
        print(
            f"{row['robot']:8} {row['method']:9} {tick['p50']:12.0f} {tick['p99']:12.0f} "
            f"{row['realtime_factor']:6.2f}  {row['fell']}"
        )
    return 0
