"""The native kernel's hierarchy methods on the same recorded states, alternated (a benchmark).

    .venv/bin/python benchmarks/bench_methods.py [--blocks 3] [--cases anymal_stand ...]

Each case runs a native `cascade` session (standing 0.3 s, pushed sideways with 0.1 of the
weight for 0.1 s, and for `anymal_trot` trotting at 0.3 m/s; Talos in Herzog's single support,
Table 4 with LQR; Bolt on its default stack) and records every tick's state and references. Then
in blocks, each method in turn replays the whole recording through the native kernel
(`controller.compute`, the warm starts carried from tick to tick as in a session), so that every
method sees the same states and, alternated, the same machine load. It prints per case and
method the median and p99 of the kernel's own solve time and of its update + solve (µs,
`Kernel.seconds`, no Python around them), and each median's ratio to the cascade's: on a loaded
machine the ratios are what to compare between runs.
"""

import argparse
import copy
import os
from dataclasses import dataclass

import numpy as np

from lab.world.session import Session, SessionConfig


@dataclass(frozen=True)
class Case:
    """A robot in a situation, the commands that set it up and the methods to time."""

    robot: str
    commands: tuple[tuple[str, dict], ...]
    methods: tuple[str, ...]


ALL = ("cascade", "weighted", "nullspace")
CASES = {
    "anymal_stand": Case("anymal", (), ALL),
    "anymal_trot": Case(
        "anymal",
        (("gait", {"name": "trot"}), ("velocity", {"vx": 0.3, "vy": 0.0, "yaw_rate": 0.0})),
        ALL,
    ),
    "talos_stand": Case("talos", (), ALL),
    "talos_single": Case(
        "talos", (("momentum", {"mode": "lqr"}), ("stance", {"side": "left"})), ALL
    ),
    "bolt_stand": Case("bolt", (), (*ALL, "wbosc")),
}
STAND_TICKS, PUSHED_TICKS, WALK_TICKS = 300, 200, 300


def recorded(case: Case) -> tuple[Session, list[tuple[np.ndarray, np.ndarray, object]]]:
    """A native cascade session of the case and its (q, v, references) of every tick."""
    session = Session(SessionConfig(robot=case.robot, method="cascade", kernel="native"))
    for verb, payload in case.commands:
        reply = session.handle(verb, payload)
        assert reply["ok"], reply
        if "preset" in reply:  # a gait's stack preset: keep the cascade while recording
            session.handle("hierarchy", {"method": "cascade"})
    states = []
    push = {"body": session.robot.base_link, "force": [0.0, 0.1 * session.model.mass * 9.81, 0]}
    walking = any(verb == "gait" for verb, _ in case.commands)
    for i in range(STAND_TICKS + PUSHED_TICKS + (WALK_TICKS if walking else 0)):
        if i == STAND_TICKS:
            session.handle("push", {**push, "duration": 0.1})
        states.append(
            (
                session.model.q.copy(),
                session.model.v.copy(),
                copy.deepcopy(session.controller.references),
            )
        )
        session.tick()
    assert not session.fell, case
    return session, states


def replay(session: Session, method: str, states: list) -> np.ndarray:
    """(solve, update + solve) seconds of the native kernel at each recorded state."""
    assert session.handle("hierarchy", {"method": method})["ok"]
    controller = session.controller
    seconds = np.zeros((len(states), 2))
    for i, (q, v, refs) in enumerate(states):
        controller.references = refs
        controller.compute(q, v)
        assert controller.kernel_ran == "native", controller.kernel_note
        update, solve = controller.kernel_seconds
        seconds[i] = solve, update + solve
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blocks", type=int, default=3, help="replays of each method")
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument(
        "--methods", nargs="+", choices=(*ALL, "wbosc"), help="of each case's (default: all)"
    )
    args = parser.parse_args()
    print(f"load average at the start: {os.getloadavg()[0]:.1f}")
    for name in args.cases:
        case = CASES[name]
        session, states = recorded(case)
        methods = [m for m in case.methods if args.methods is None or m in args.methods]
        times: dict[str, list[np.ndarray]] = {method: [] for method in methods}
        for _ in range(args.blocks):
            for method in methods:
                times[method].append(replay(session, method, states))
        us = {method: np.concatenate(blocks) * 1e6 for method, blocks in times.items()}
        base = np.median(us["cascade"], axis=0) if "cascade" in us else None
        for method, t in us.items():
            p50, p99 = np.median(t, axis=0), np.percentile(t, 99, axis=0)
            line = (
                f"{name:13s} {method:9s} solve p50 {p50[0]:6.1f} p99 {p99[0]:7.1f} | "
                f"update+solve p50 {p50[1]:6.1f} p99 {p99[1]:7.1f}"
            )
            if base is not None:
                ratio = p50 / base
                line += f" | /cascade {ratio[0]:.2f} (update+solve {ratio[1]:.2f})"
            print(line)
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
