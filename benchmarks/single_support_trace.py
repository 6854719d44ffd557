"""Why the cascade costs what it costs in single support: a per-level trace of its QPs.

    .venv/bin/python benchmarks/single_support_trace.py [--robots talos_arms g1] [--ticks 2000]
    .venv/bin/python benchmarks/single_support_trace.py --scenario scenarios/X.toml [--between 0 12]

Per robot: a Python-kernel session under Herzog's Table 4 stack with the LQR momentum law on the
left sole (`lab bench --gaits single`'s set-up), whose hierarchy problems of the last `--window`
ticks are kept. Each kept problem is solved again by the Python cascade, every QP it poses
re-solved with the native kernel's DAQP for its iteration count, and by the native cascade for
its level statuses. Prints how the ticks split by level statuses, the size of each QP (variables,
rows), DAQP's iterations and final active rows, and which inequality rows the cascade's
equality-only pass violates (the reason the QP path runs), named by constraint and joint.
`--scenario` traces the same for a shipped scenario's ticks between two sim times instead, its
events played as `lab run` plays them, on the Python kernel.
Counts, not times: they hold under any load.
"""

import argparse
import collections
import os
from dataclasses import replace
from pathlib import Path

import numpy as np

import lab.controller.hierarchy.cascade as cascade
from lab import _kernel
from lab.controller.hierarchy.problem import HierarchyProblem
from lab.controller.hierarchy.solution import LevelClock
from lab.controller.tasks.posture import leg_joints
from lab.experiments.bench import GAITS
from lab.experiments.limits import apply_limits
from lab.experiments.scenario import load_scenario
from lab.world.session import Session, SessionConfig

ACTIVE_TOL = 1e-7  # a row within this of its bound counts as active
JOINT_ROWS = ("torque_limits", "joint_limits")  # rows [+joint; −joint], one per actuated joint


def single_support_problems(robot: str, ticks: int, window: int) -> tuple[list, list[str]]:
    """The hierarchy problems of the last `window` of `ticks` single-support ticks, and the
    robot's actuated joint names; prints the joints that moved farthest from the start."""
    session = Session(SessionConfig(robot=robot, method="cascade", kernel="python"))
    for verb, payload in GAITS["single"].commands:
        reply = session.handle(verb, payload)
        if not reply["ok"]:
            raise SystemExit(f"single_support_trace: {robot}: {verb}: {reply['error']}")
        if "preset" in reply:
            session.handle("hierarchy", {"method": "cascade"})
    controller = session.controller
    build = controller.build_problem
    kept: list[HierarchyProblem] = []

    def keep() -> HierarchyProblem:
        problem = build()
        kept.append(problem)
        return problem

    controller.build_problem = keep
    start = controller.robot.joint_positions.copy()
    farthest = np.zeros_like(start)
    for _ in range(ticks):
        session.tick()
        np.maximum(farthest, np.abs(controller.robot.joint_positions - start), out=farthest)
    if session.fell:
        raise SystemExit(f"single_support_trace: {robot} fell")
    joints = list(controller.robot.model.names[2:])
    moved = ", ".join(f"{joints[j]} {farthest[j]:.2f}" for j in np.argsort(farthest)[::-1][:3])
    print(f"{robot}: farthest from the start posture over the run (rad): {moved}")
    upper = np.ones(len(joints), dtype=bool)  # the upper_body task's joints: in no leg
    for leg in leg_joints(controller.robot):
        upper[leg] = False
    if upper.any():
        j = np.flatnonzero(upper)[np.argmax(farthest[upper])]
        print(f"  the upper body's farthest (joints in no leg): {joints[j]} {farthest[j]:.4f} rad")
    return kept[-window:], joints


def scenario_problems(path: Path, start: float, end: float) -> tuple[list, list[str]]:
    """The hierarchy problems of scenario `path`'s ticks from `start` to `end` (sim s), on the
    Python kernel, and the robot's actuated joint names."""
    scenario = load_scenario(path)
    session = Session(replace(scenario.config, kernel="python"))
    apply_limits(session.controller, scenario.limits)
    controller = session.controller
    build = controller.build_problem
    kept: list[HierarchyProblem] = []

    def keep() -> HierarchyProblem:
        problem = build()
        if session.time >= start - 1e-9:
            kept.append(problem)
        return problem

    controller.build_problem = keep
    pending = list(scenario.events)
    while session.time < end - 1e-9 and not session.fell:
        while pending and pending[0].t <= session.time + 1e-9:
            event = pending.pop(0)
            session.handle(event.verb, event.payload)
        session.tick()
    return kept, list(controller.robot.model.names[2:])


def violated_rows(problem: HierarchyProblem, joints: list[str]) -> list[tuple[int, str]]:
    """(level, row name) of every inequality the equality-only pass's x violates."""
    x = cascade._equalities_only(problem, LevelClock(len(problem.levels)))
    out = []
    for depth, level in enumerate(problem.levels):
        start = 0
        for name, count in level.constraint_rows:
            excess = level.C[start : start + count] @ x - level.d[start : start + count]
            for row in np.flatnonzero(excess > cascade.FEASIBILITY_TOL):
                if name in JOINT_ROWS:
                    side = "upper" if row < len(joints) else "lower"
                    out.append((depth, f"{name} {joints[row % len(joints)]} {side}"))
                else:
                    out.append((depth, f"{name} row {row}"))
            start += count
    return out


def trace(problems: list[HierarchyProblem], joints: list[str]) -> None:
    """Print the split of the ticks, the QPs' sizes and iterations, and the violated rows."""
    posed: list[tuple[int, int, int, int]] = []  # (variables, rows, iterations, active)
    python_solve = cascade.solve_qp

    def counted(P, q, G, h, solver="daqp"):
        x = python_solve(P, q, G, h, solver=solver)
        *_, iterations = _kernel.solve_qp(P, q, G, h, np.zeros((0, len(q))), np.zeros(0))
        posed.append((len(q), len(h), iterations, int(np.sum(G @ x > h - ACTIVE_TOL))))
        return x

    statuses: collections.Counter = collections.Counter()
    agree = 0
    violated: collections.Counter = collections.Counter()
    cascade.solve_qp = counted
    try:
        for problem in problems:
            solution = cascade.solve_cascade(problem)
            levels = [(lv.A, lv.b, lv.C, lv.d, lv.weight) for lv in problem.levels]
            native = _kernel.solve_hierarchy(
                "cascade", problem.dynamics_A, problem.dynamics_b, levels, problem.terms.support
            )
            agree += tuple(native["levels"]) == solution.levels
            statuses[(solution.levels, solution.qp_solves)] += 1
            violated.update(set(violated_rows(problem, joints)))
    finally:
        cascade.solve_qp = python_solve
    n = len(problems)
    print(f"  ticks {n}; native cascade's level statuses equal to Python's on {agree}")
    print(
        f"  level equality rows {[lv.A.shape[0] for lv in problems[-1].levels]}, "
        f"inequality rows {[lv.C.shape[0] for lv in problems[-1].levels]}, x {problems[-1].nx}"
    )
    for (levels, solves), count in statuses.most_common():
        print(f"  {count / n:6.1%} of ticks: levels {', '.join(levels)}; {solves} QP solves")
    sizes = collections.Counter((nv, m) for nv, m, _, _ in posed)
    for (nv, m), count in sizes.most_common():
        its = [it for v, r, it, _ in posed if (v, r) == (nv, m)]
        act = [a for v, r, _, a in posed if (v, r) == (nv, m)]
        print(
            f"  QP {nv} variables x {m} rows: {count / n:.2f} per tick, DAQP iterations "
            f"median {np.median(its):.0f} (max {max(its)}), active rows median {np.median(act):.0f}"
        )
    for (depth, row), count in violated.most_common(8):
        print(
            f"  violated by the equality-only x on {count / n:6.1%} of ticks: level {depth} {row}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=["talos_arms", "g1", "talos"])
    parser.add_argument("--ticks", type=int, default=2000, help="single-support ticks run")
    parser.add_argument("--window", type=int, default=2000, help="last ticks traced")
    parser.add_argument("--scenario", type=Path, help="trace this scenario's ticks instead")
    parser.add_argument(
        "--between", type=float, nargs=2, default=(0.0, 12.0), help="--scenario's window, sim s"
    )
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f}")
    if args.scenario is not None:
        start, end = args.between
        problems, joints = scenario_problems(args.scenario, start, end)
        print(f"{args.scenario.stem} (Python kernel; ticks {start:g}-{end:g} s):")
        trace(problems, joints)
        return
    for robot in args.robots:
        problems, joints = single_support_problems(robot, args.ticks, args.window)
        first = max(args.ticks - args.window, 0)
        print(f"{robot} (Table 4, LQR, left sole; ticks {first}-{args.ticks}):")
        trace(problems, joints)


if __name__ == "__main__":
    main()
