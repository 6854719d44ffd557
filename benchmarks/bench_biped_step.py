"""Bolt's stepping behaviour per tick: Python against its native tick, replanning or not (a
benchmark).

    .venv/bin/python benchmarks/bench_biped_step.py [--seconds 3] [--repeats 5]

Bolt walks at 0.2 m/s while turning at 0.3 rad/s under Kim's stack on the native cascade
(its stepping tick in C++), and each tick's behaviour inputs are recorded. Then the recorded
ticks are replayed `--repeats` times through two fresh BipedStepping objects, one on its Python
steps and one on its native tick, each call timed (thread CPU time, µs); replanning ticks (the
planner ran: from 80 % of each lift until landing) are reported apart. Prints median and p99.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from lab.controller.behaviours.biped_step import BipedStepping
from lab.controller.model import RobotModel
from lab.world.session import Session, SessionConfig

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests.helpers.native_ticks import recording  # the agreement tests' recorder


def recorded_walk(seconds: float) -> tuple:
    """A native Bolt session walking and turning: the robot and (t, q, v, command, touching)."""
    session = Session(SessionConfig(robot="bolt"))
    session.native_ticks = False  # the recorder wraps `update`, which the Python tick calls
    session.handle("gait", {"name": "biped_step"})
    session.handle("hierarchy", {"method": "cascade"})
    session.velocity = np.array([0.2, 0.0, 0.3])
    calls = recording(session)
    while session.time < seconds and not session.fell:
        session.tick()
    if session.fell:
        raise SystemExit("bench_biped_step: Bolt fell while recording")
    return session.robot, calls


def replay(robot, calls: list, native: bool) -> tuple[np.ndarray, np.ndarray]:
    """Each call's time (µs) and whether it replanned, for one fresh BipedStepping."""
    model = RobotModel(robot.model, robot.contacts)
    model.update(robot.q_standing, np.zeros(robot.model.nv))
    stepping = BipedStepping(model, robot.q_standing)
    us, replanned = np.zeros(len(calls)), np.zeros(len(calls), dtype=bool)
    for i, (t, q, v, command, touching) in enumerate(calls):
        model.update(q, v)
        if native:
            model.filled_elsewhere()
        plans = stepping.plans
        start = time.thread_time_ns()
        stepping.update(t, model, command, touching)
        us[i] = (time.thread_time_ns() - start) * 1e-3
        replanned[i] = stepping.plans != plans
    return us, replanned


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated seconds recorded")
    parser.add_argument("--repeats", type=int, default=5, help="replays per side, alternated")
    args = parser.parse_args()
    robot, calls = recorded_walk(args.seconds)
    times = {False: [], True: []}
    for _ in range(args.repeats):
        for native in (False, True):
            times[native].append(replay(robot, calls, native))
    print(f"{len(calls)} ticks recorded; thread CPU time per behaviour tick, µs")
    print(
        f"{'side':8} {'ticks':>8} {'all p50':>8} {'all p99':>8} {'replan p50':>11} "
        f"{'replan p99':>11} {'other p50':>10}"
    )
    for native, runs in times.items():
        us = np.concatenate([u for u, _ in runs])
        replanned = np.concatenate([r for _, r in runs])
        print(
            f"{'native' if native else 'python':8} {len(us):8d} {np.median(us):8.1f} "
            f"{np.percentile(us, 99):8.1f} {np.median(us[replanned]):11.1f} "
            f"{np.percentile(us[replanned], 99):11.1f} {np.median(us[~replanned]):10.1f}"
        )


if __name__ == "__main__":
    main()
