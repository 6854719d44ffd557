"""Cost against degrees of freedom: `lab bench`'s standing run (cascade, native kernel) over every
robot, as the markdown table of docs/performance.md ("Cost against DoF").

    .venv/bin/python benchmarks/cost_vs_dof.py [--seconds 3] [--robots ...]

Per robot, in order of nv: the tick's median and p99 (what the session pays per control period),
the native kernel's own median (model update, rows, solve, timed inside it) and the real-time
factor of the run, with the load average before and after the whole table.
"""

import argparse
import os

from lab.description import ROBOT_NAMES
from lab.experiments.bench import bench_one


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated seconds per robot")
    parser.add_argument("--robots", nargs="+", default=list(ROBOT_NAMES), choices=ROBOT_NAMES)
    args = parser.parse_args()
    load_before = os.getloadavg()[0]
    rows = [bench_one(robot, "cascade", args.seconds, "native", "stand") for robot in args.robots]
    load_after = os.getloadavg()[0]
    print(f"load average {load_before:.1f} before, {load_after:.1f} after; {args.seconds} s each")
    print("| robot | nv | ran | tick p50 / p99 µs | in-kernel p50 µs | RTF | fell |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for row in sorted(rows, key=lambda r: (r["nv"], r["robot"])):
        tick, inside = row["controller_us"], row["kernel_us"]
        kernel = f"{inside['p50']:.0f}" if inside else "–"
        print(
            f"| {row['robot']} | {row['nv']} | {row['kernel']} {row['method']} | "
            f"{tick['p50']:.0f} / {tick['p99']:.0f} | {kernel} | "
            f"{row['realtime_factor']:.2f}× | {'yes' if row['fell'] else 'no'} |"
        )


if __name__ == "__main__":
    main()
