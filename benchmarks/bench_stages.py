"""Where a session tick goes: median thread-CPU time of each stage (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_stages.py [--robot anymal] [--trot] [--ticks 3000]
                                                [--kernel python|native]
    .venv/bin/python benchmarks/bench_stages.py --whole [--robot anymal] [--trot]

Standing uses the robot's default stack; `--trot` trots at 0.5 m/s under Raiola's S3 (the stack
the gait command brings). Each stage is timed with `time.thread_time()` after 1.5 s of warm-up,
so time the thread spent descheduled does not count. With `--kernel native` the model update is
the kernel's (it fills the Python model's arrays for the behaviour) and `controller` is
`controller.solve()`: references read, rows, method and torques in one call.

`--whole` times the whole `Session.tick()` instead, on two sessions of the native kernel in the
same run, ticking in turns: one on the server's native tick (one crossing, native_tick.py), one
on the Python tick (`Session.native_ticks = False`); median and p99 of each, and their ratio;
and of the native tick's, the part inside C++ and the rest (`Python`, tick by tick).
"""

import argparse
import time

import numpy as np

from lab.controller.hierarchy import METHODS
from lab.world.session import Session, SessionConfig
from lab.world.session_tick import TOUCH_FORCE

WARM_UP_TICKS = 1500
STAGES = ("state", "touch", "model", "behaviour", "rows", "solve", "torques", "plant step")
NATIVE_STAGES = ("state", "touch", "model", "behaviour", "controller", "plant step")


def python_controller(
    session: Session, q: np.ndarray, v: np.ndarray, touching, marks
) -> np.ndarray:
    """The Python kernel's stages: model update, behaviour, rows, method, torques."""
    controller, model, clock = session.controller, session.model, time.thread_time
    model.update(q, v)
    marks.append(clock())
    session.behaviour.update(session.time, model, session.velocity, touching)
    marks.append(clock())
    problem = controller.build_problem()
    marks.append(clock())
    x = METHODS[controller.config.method](problem, controller.config.solver).x
    marks.append(clock())
    return model.joint_torques(x)


def native_controller(
    session: Session, q: np.ndarray, v: np.ndarray, touching, marks
) -> np.ndarray:
    """The native kernel's stages: its model update, behaviour, then one controller.solve()."""
    controller, clock = session.controller, time.thread_time
    controller.update(q, v)
    marks.append(clock())
    session.behaviour.update(session.time, session.model, session.velocity, touching)
    marks.append(clock())
    return controller.solve().tau


def measure(robot: str, trot: bool, ticks: int, kernel: str = "python") -> dict[str, float]:
    session = Session(SessionConfig(robot=robot, kernel=kernel))
    if trot:
        session.handle("gait", {"name": "trot"})
        session.handle("velocity", {"vx": 0.5})
    for _ in range(WARM_UP_TICKS):
        session.tick()
    plant, clock = session.plant, time.thread_time
    stages, control = (
        (NATIVE_STAGES, native_controller) if kernel == "native" else (STAGES, python_controller)
    )
    spent = np.zeros((ticks, len(stages)))
    for i in range(ticks):
        marks = [clock()]
        q, v = plant.state()
        marks.append(clock())
        touching = plant.feet_touching(TOUCH_FORCE)
        marks.append(clock())
        tau = control(session, q, v, touching, marks)
        marks.append(clock())
        plant.set_torques(tau)
        plant.step()
        marks.append(clock())
        spent[i] = np.diff(marks)
    if kernel == "native" and session.controller.kernel_ran != "native":
        raise SystemExit(f"the native kernel did not run: {session.controller.kernel_note}")
    return dict(zip(stages, np.median(spent, axis=0) * 1e6, strict=True))


def measure_whole(robot: str, trot: bool, ticks: int) -> dict[str, tuple[float, float]]:
    """Thread-CPU µs (median, p99) of `Session.tick()` on the native tick and on the Python tick,
    the two sessions ticking in turns (the same load on both); and of the native tick, the
    part inside its one call (`in C++`) and of that the check-to-solve part (`control`),
    both on the steady clock inside C++, and the rest of each native tick (`Python`: the
    session's Python around the crossing and the crossing's own cost, tick by tick)."""
    sessions = {
        "native": Session(SessionConfig(robot=robot)),
        "python": Session(SessionConfig(robot=robot)),
    }
    sessions["python"].native_ticks = False
    for session in sessions.values():
        if trot:
            session.handle("gait", {"name": "trot"})
            session.handle("velocity", {"vx": 0.5})
        for _ in range(WARM_UP_TICKS):
            session.tick()
    spent = {path: np.zeros(ticks) for path in (*sessions, "in C++", "control", "Python")}
    clock, native = time.thread_time, sessions["native"].native_tick
    for i in range(ticks):
        for path, session in sessions.items():
            start = clock()
            session.tick()
            spent[path][i] = clock() - start
        spent["in C++"][i] = native.call_us * 1e-6  # steady clock, inside the one call
        spent["control"][i] = native.control_us * 1e-6
        spent["Python"][i] = spent["native"][i] - spent["in C++"][i]
    for path, session in sessions.items():
        if session.tick_report()["tick"] != path or session.fell:
            raise SystemExit(f"the {path} tick did not run to the end: {session.tick_report()}")
    return {
        path: (float(np.median(us)) * 1e6, float(np.percentile(us, 99)) * 1e6)
        for path, us in spent.items()
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="anymal")
    parser.add_argument("--trot", action="store_true", help="trot at 0.5 m/s instead of standing")
    parser.add_argument("--ticks", type=int, default=3000)
    parser.add_argument("--kernel", choices=("python", "native"), default="python")
    parser.add_argument("--whole", action="store_true", help="time Session.tick(), both paths")
    args = parser.parse_args()
    doing = "trotting" if args.trot else "standing"
    if args.whole:
        whole = measure_whole(args.robot, args.trot, args.ticks)
        print(
            f"{args.robot} {doing}, Session.tick() µs of thread CPU time over {args.ticks} ticks:"
        )
        for path, (median, p99) in whole.items():
            print(f"  {path:7s} median {median:6.1f}  p99 {p99:6.1f}")
        print(f"  native / python median: {whole['native'][0] / whole['python'][0]:.2f}")
        return
    medians = measure(args.robot, args.trot, args.ticks, args.kernel)
    print(
        f"{args.robot} {doing}, {args.kernel} kernel, median µs of thread CPU time over "
        f"{args.ticks} ticks:"
    )
    for stage, us in medians.items():
        print(f"  {stage:11s} {us:6.0f}")
    print(f"  {'sum':11s} {sum(medians.values()):6.0f}")


if __name__ == "__main__":
    main()
