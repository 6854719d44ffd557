"""Trot real-time factor with the walking behaviour's native tick and without (a benchmark).

    .venv/bin/python benchmarks/bench_trot.py [--robot anymal] [--blocks 20] [--ticks 1000]
                                              [--profile]

The robot trots at 0.5 m/s under Raiola's S3 (the stack the gait command brings) on the native
kernel, headless. After 1.5 s of warm-up, blocks of `--ticks` session ticks alternate between the
walking behaviour's native tick (cpp/behaviours/walking.cpp) and its Python steps (walking.py
with the native tick switched off; the leg posture's q̇_d stays native as before), so that both
see the same machine load. Per side it prints the median and the minimum over blocks of the
thread CPU time per tick (µs; its real-time factor if the session were CPU-bound) and of the
wall-clock real-time factor. `--profile` prints cProfile's top functions of one block per side
instead.
"""

import argparse
import cProfile
import pstats
import time

import numpy as np

from lab.world.session import Session, SessionConfig

WARM_UP_TICKS = 1500
SIDES = ("python walking", "native walking")


def trotting_session(robot: str) -> Session:
    session = Session(SessionConfig(robot=robot, kernel="native"))
    session.handle("gait", {"name": "trot"})
    session.handle("velocity", {"vx": 0.5})
    for _ in range(WARM_UP_TICKS):
        session.tick()
    if session.controller.kernel_ran != "native":
        raise SystemExit(f"the native kernel did not run: {session.controller.kernel_note}")
    if session.behaviour._native is None:
        raise SystemExit("the kernel has no native walking tick (lab._kernel.Walking)")
    return session


def run_block(session: Session, native: object, ticks: int) -> tuple[float, float]:
    """Thread CPU seconds and wall seconds of `ticks` ticks with the walking's native tick
    `native` (None: the Python steps)."""
    session.behaviour._native = native
    session.behaviour._native_stale = True
    cpu, wall = time.thread_time(), time.perf_counter()
    for _ in range(ticks):
        session.tick()
    return time.thread_time() - cpu, time.perf_counter() - wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="anymal")
    parser.add_argument("--blocks", type=int, default=20, help="blocks per side")
    parser.add_argument("--ticks", type=int, default=1000, help="ticks per block")
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args()
    session = trotting_session(args.robot)
    native, dt = session.behaviour._native, session.config.timestep
    if args.profile:
        for side, tick in zip(SIDES, (None, native), strict=True):
            profile = cProfile.Profile()
            profile.runcall(run_block, session, tick, args.ticks)
            print(f"--- {side}: cProfile of {args.ticks} ticks (own time, top 25)")
            pstats.Stats(profile).sort_stats("tottime").print_stats(25)
        return
    cpu = {side: [] for side in SIDES}
    wall = {side: [] for side in SIDES}
    for _ in range(args.blocks):
        for side, tick in zip(SIDES, (None, native), strict=True):
            c, w = run_block(session, tick, args.ticks)
            cpu[side].append(c / args.ticks * 1e6)
            wall[side].append(args.ticks * dt / w)
    if session.fell:
        raise SystemExit("the robot fell: the numbers are not a trot's")
    print(
        f"{args.robot} trot 0.5 m/s, {args.blocks} alternating blocks of {args.ticks} ticks "
        "per side"
    )
    print(
        f"{'':16} {'CPU µs/tick p50 / min':>22} {'RTF if CPU-bound':>17} {'RTF wall p50 / max':>19}"
    )
    for side in SIDES:
        us, rtf = np.array(cpu[side]), np.array(wall[side])
        print(
            f"{side:16} {np.median(us):10.0f} / {us.min():5.0f} "
            f"{dt * 1e6 / np.median(us):8.2f} / {dt * 1e6 / us.min():4.2f} "
            f"{np.median(rtf):10.2f} / {rtf.max():5.2f}"
        )
    ratio = np.median(cpu[SIDES[1]]) / np.median(cpu[SIDES[0]])
    print(f"native / python walking, CPU per tick (medians): {ratio:.2f}")


if __name__ == "__main__":
    main()
