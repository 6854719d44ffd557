"""What the 1 kHz loop's side jobs cost, part by part (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_jobs.py [--robot anymal] [--trot] [--reps 2000]

The loop builds a telemetry message (100 Hz) and a drawing state (60 Hz) on ticks of their own
and encodes them on the tick that publishes (lab/runtime/loop.py). On a running session (after
1 s of warm-up) each repetition is a session tick, then the drawing state built whole (`after a
tick`: caches as the loop's job tick finds them), another session tick, the telemetry message
built whole, then each part in a hot loop (`hot`), the encoding of the messages just built
last. Prints median, p99 and minimum of each in µs. Standing uses the robot's default stack;
`--trot` trots at 0.5 m/s (the gait command's stack).

`--cold` times each part the way the server's loop finds it instead: first after
COLD_PERIODS periods of the loop (sleep ~0.8 ms, one session tick), with the caches as sleeping
and the session tick left them; in the server the side jobs cost 3-5x their hot time
(`git show fe8d29c:docs/performance.md`, round 10).
"""

import argparse
import time
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from lab.runtime.transport import encode
from lab.world import telemetry
from lab.world.session import Session, SessionConfig

WARM_UP_TICKS = 1000
COLD_PERIODS = 3
COLD_SLEEP_S = 8e-4


def parts(session: Session) -> dict[str, Callable[[], object]]:
    """The jobs and their parts, each a call on the running session."""
    model, controller, frames = session.model, session.controller, session.frame_placements
    q = session.plant.state()[0]
    data = model.model.createData()

    def read_joint_placements() -> object:
        pin.forwardKinematics(model.model, data, q)
        return [placement.homogeneous for placement in data.oMi]

    state, message = telemetry.state_message(session), telemetry.telemetry_message(session)
    _, finish = telemetry.telemetry_in_two(session)
    return {
        "state: whole": lambda: telemetry.state_message(session),
        "state: plant.state": session.plant.state,
        "state: joint_names": lambda: list(session.robot.joint_names),
        "state: frames.message": lambda: frames.message(q),
        "state:   fk + oMi.homogeneous": read_joint_placements,
        "state: encode": lambda: encode(state),
        "telemetry: whole": lambda: telemetry.telemetry_message(session),
        "telemetry: in two, first": lambda: telemetry.telemetry_in_two(session),
        "telemetry: in two, finish": finish,
        "telemetry: contacts + cop": lambda: telemetry._contacts(session),
        "telemetry: tasks": lambda: telemetry._tasks(controller, controller.task_errors()),
        "telemetry: stack.as_lists": controller.config.stack.as_lists,
        "telemetry: momentum": model.centroidal_momentum,
        "telemetry: internal_force": lambda: telemetry.internal_force_report(controller),
        "telemetry: stepping": lambda: telemetry.stepping_report(session.behaviour, model),
        "telemetry: momentum_control": lambda: telemetry.momentum_report(controller),
        "telemetry: warnings": session.recent_warnings,
        "telemetry: solution": lambda: (
            None if session.solution is None else session.solution.summary()
        ),
        "telemetry: base + com": lambda: (
            model.q[:7].tolist(),
            (model.base_rotation @ model.v[:3]).tolist(),
            (model.base_rotation @ model.v[3:6]).tolist(),
            model.com.tolist(),
            model.com_velocity.tolist(),
        ),
        "telemetry: encode": lambda: encode(message),
    }


def measure(robot: str, trot: bool, reps: int, cold: bool = False) -> dict[str, np.ndarray]:
    """Each part's time (µs) on each of `reps` repetitions, one session tick apart (`cold`:
    each part first after COLD_PERIODS loop periods)."""
    session = Session(SessionConfig(robot=robot))
    if trot:
        session.handle("gait", {"name": "trot"})
        session.handle("velocity", {"vx": 0.5})
    for _ in range(WARM_UP_TICKS):
        session.tick()
    times: dict[str, list[float]] = {}
    clock = time.perf_counter_ns
    for _ in range(reps):
        for name, job in (
            ("state", telemetry.state_message),
            ("telemetry", telemetry.telemetry_message),
        ):
            session.tick()
            start = clock()
            job(session)
            times.setdefault(f"{name}: whole, after a tick", []).append((clock() - start) / 1e3)
        for name, call in parts(session).items():
            for _ in range(COLD_PERIODS if cold else 0):
                time.sleep(COLD_SLEEP_S)
                session.tick()
            start = clock()
            call()
            times.setdefault(name, []).append((clock() - start) / 1e3)
    return {name: np.array(t) for name, t in times.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robot", default="anymal")
    parser.add_argument("--trot", action="store_true")
    parser.add_argument("--reps", type=int, default=2000)
    parser.add_argument("--cold", action="store_true", help="each part after loop periods")
    args = parser.parse_args()
    times = measure(args.robot, args.trot, args.reps, args.cold)
    how = "cold (after loop periods)" if args.cold else "hot"
    print(f"{args.robot} {'trot' if args.trot else 'stand'}, {args.reps} reps, {how}, µs")
    print(f"{'part':34s} {'median':>8s} {'p99':>8s} {'min':>8s}")
    for name, t in times.items():
        print(f"{name:34s} {np.median(t):8.1f} {np.percentile(t, 99):8.1f} {t.min():8.1f}")


if __name__ == "__main__":
    main()
