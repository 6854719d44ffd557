"""Cost against degrees of freedom: `lab bench`'s standing run (cascade, native kernel) per robot,
as the markdown table of docs/performance.md ("Cost against DoF").

    .venv/bin/python benchmarks/cost_vs_dof.py [--seconds 3] [--robots ...]

Per robot, in order of nv: the tick's median and p99 (what the session pays per control period),
the native kernel's own median (model update, rows, solve, timed inside it) and each of its
stages' medians (`Kernel.seconds`: the model update with the copy into the Python model's arrays,
the rows of every task and constraint, the hierarchy method with the torques), which stage
dominates, and the real-time factor of the run; the load average before and after the whole
table; then how each stage grows: the exponent p of a least-squares fit of its median ∝ nv^p over
the robots (log-log), with its first and last row's medians.
"""

import argparse
import os

import numpy as np

from lab.description import ROBOT_NAMES
from lab.experiments.bench import KERNEL_STAGES, bench_one

# Issue 29's robots: the 18-DoF quadrupeds, the quadruped with an arm, the humanoids with arms.
ROBOTS = ("solo12", "go2", "anymal", "b1_z1", "g1", "talos_arms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated seconds per robot")
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS), choices=ROBOT_NAMES)
    args = parser.parse_args()
    load_before = os.getloadavg()[0]
    rows = [bench_one(robot, "cascade", args.seconds, "native", "stand") for robot in args.robots]
    load_after = os.getloadavg()[0]
    rows.sort(key=lambda r: (r["nv"], r["robot"]))
    print(f"load average {load_before:.1f} before, {load_after:.1f} after; {args.seconds} s each")
    stages = " | ".join(f"{stage} µs" for stage in KERNEL_STAGES)
    print(
        f"| robot | nv | ran | tick p50 / p99 µs | in-kernel p50 µs | {stages} | dominant | RTF |"
    )
    print("| --- " * (7 + len(KERNEL_STAGES)) + "|")
    for row in rows:
        tick, inside, split = row["controller_us"], row["kernel_us"], row["kernel_stages_us"]
        kernel = f"{inside['p50']:.0f}" if inside else "–"
        parts = " | ".join(f"{split[s]:.0f}" if split else "–" for s in KERNEL_STAGES)
        dominant = max(split, key=lambda s: split[s]) if split else "–"
        fell = " (fell)" if row["fell"] else ""
        print(
            f"| {row['robot']} | {row['nv']} | {row['kernel']} {row['method']} | "
            f"{tick['p50']:.0f} / {tick['p99']:.0f} | {kernel} | {parts} | {dominant} | "
            f"{row['realtime_factor']:.2f}×{fell} |"
        )
    timed = [row for row in rows if row["kernel_stages_us"]]
    if len({row["nv"] for row in timed}) > 1:
        nv = np.array([row["nv"] for row in timed], dtype=float)
        growth = []
        for stage in KERNEL_STAGES:
            us = np.array([row["kernel_stages_us"][stage] for row in timed])
            exponent = np.polyfit(np.log(nv), np.log(us), 1)[0]
            growth.append(f"{stage} ∝ nv^{exponent:.1f} ({us[0]:.0f} → {us[-1]:.0f} µs)")
        print(f"growth from nv = {nv[0]:.0f} to {nv[-1]:.0f}: " + "; ".join(growth))


if __name__ == "__main__":
    main()
