"""The standing behaviours' native twins in a native session: each situation's control tick and
real-time factor with the behaviour's update in C++ against the same session with its Python
update (a benchmark).

    .venv/bin/python benchmarks/bench_behaviours.py [--seconds 3] [--repeats 3]

Each situation runs on the native kernel `--repeats` times per side, the sides alternated: `twin`
(the behaviour's native tick, cpp/behaviours) and `python` (the same session with the
behaviour's twin removed, so that its Python update runs on each native tick, as before the twins
existed). `tick` is the session's control period (model update, behaviour, solve: control_us);
RTF is simulated over wall time of the whole session tick (the plant included). Prints median
and p99 of all repeats, and twin/python of the tick medians.
"""

import argparse
import time

import numpy as np

from lab.world.session import Session, SessionConfig

SITUATIONS: dict[str, tuple[str, tuple[tuple[str, dict], ...]]] = {
    "bolt stand": ("bolt", ()),
    "bolt com_ellipse": ("bolt", (("gait", {"name": "com_ellipse"}),)),
    "talos single": ("talos", (("momentum", {"mode": "lqr"}), ("stance", {"side": "left"}))),
    "talos squat": ("talos", (("stack", {"preset": "herzog_table2"}), ("gait", {"name": "squat"}))),
    "anymal forward_shift": ("anymal", (("gait", {"name": "forward_shift"}),)),
    "anymal static_walk": ("anymal", (("gait", {"name": "static_walk"}),)),
}


def run(robot: str, commands: tuple, seconds: float, twin: bool) -> tuple[np.ndarray, float, str]:
    """One native session of `seconds`: each tick's control time (µs), the real-time factor and
    which kernel ran the behaviour's last update."""
    session = Session(SessionConfig(robot=robot))
    for verb, payload in commands:
        reply = session.handle(verb, payload)
        if not reply["ok"]:
            raise SystemExit(f"bench_behaviours: {robot}: {verb}: {reply['error']}")
    if not twin:
        session.behaviour._native = None  # its Python update on every native tick
    ticks = round(seconds / session.config.timestep)
    us = np.zeros(ticks)
    start = time.perf_counter()
    for i in range(ticks):
        session.tick()
        us[i] = session.control_us
    rtf = session.time / (time.perf_counter() - start)
    if session.fell:
        raise SystemExit(f"bench_behaviours: {robot} fell")
    return us, rtf, session.behaviour.kernel_ran


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated seconds per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs per side, alternated")
    parser.add_argument("--situations", nargs="+", default=list(SITUATIONS), choices=SITUATIONS)
    args = parser.parse_args()
    print(
        f"{'situation':22} {'side':7} {'behaviour':10} {'tick p50 µs':>12} {'tick p99 µs':>12} "
        f"{'RTF':>6}"
    )
    for name in args.situations:
        robot, commands = SITUATIONS[name]
        runs: dict[bool, list] = {True: [], False: []}
        for _ in range(args.repeats):
            for twin in (False, True):
                runs[twin].append(run(robot, commands, args.seconds, twin))
        medians = {}
        for twin, results in runs.items():
            us = np.concatenate([r[0] for r in results])
            rtf = float(np.median([r[1] for r in results]))
            medians[twin] = float(np.median(us))
            print(
                f"{name:22} {'twin' if twin else 'python':7} {results[-1][2]:10} "
                f"{medians[twin]:12.0f} {np.percentile(us, 99):12.0f} {rtf:6.2f}"
            )
        print(f"{name:22} twin/python tick p50 {medians[True] / medians[False]:.2f}")


if __name__ == "__main__":
    main()
