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

`--paced` times the native tick's stages three ways in the same run: ticking back to back
(`tight`, as `--whole`), and once per millisecond as the server's loop does (sleep until 0.05
ms before each deadline, then spin), where the caches, TLB and branch predictors go cold while
the thread sleeps and other processes run: every other such tick with the loop's warm-up after
its sleep (`warmed`: `Session.warm`, woken WARM_LEAD_S earlier for it, as lab/runtime/loop.py
does), the others without (`paced`). Wall-clock µs (perf_counter, and the steady clock inside
C++), medians per stage, and the warm-up's own time before the deadline.
"""

import argparse
import itertools
import time

import numpy as np

from lab.controller.hierarchy import METHODS
from lab.runtime.loop import WARM_LEAD_S
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


def settled(config: SessionConfig, trot: bool, native_ticks: bool = True) -> Session:
    """A session of `config` (trotting at 0.5 m/s with `trot`) after WARM_UP_TICKS ticks."""
    session = Session(config)
    session.native_ticks = native_ticks
    if trot:
        session.handle("gait", {"name": "trot"})
        session.handle("velocity", {"vx": 0.5})
    for _ in range(WARM_UP_TICKS):
        session.tick()
    return session


def measure(robot: str, trot: bool, ticks: int, kernel: str = "python") -> dict[str, float]:
    session = settled(SessionConfig(robot=robot, kernel=kernel), trot)
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
        "native": settled(SessionConfig(robot=robot), trot),
        "python": settled(SessionConfig(robot=robot), trot, native_ticks=False),
    }
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


PACED_STAGES = (
    "Session.tick",
    "in C++",
    "Python",
    "model update",
    "rows",
    "method, torques",
    "state, behaviour, references, report",
    "MuJoCo step, checks",
    "warm-up, before the deadline",
)
PERIOD_S = 1e-3  # the server's loop period
SPIN_S = 5e-5  # its default spin before each deadline (lab serve --spin-ms)
BLOCK_TICKS = 250  # ticks of one kind before switching to the other


def measure_paced(robot: str, trot: bool, ticks: int) -> dict[str, dict[str, float]]:
    """Median wall-clock µs of each of PACED_STAGES of the native server tick, ticking back to
    back (`tight`) and once per PERIOD_S as the loop does, every other such tick with the
    loop's warm-up after its sleep (`warmed`, the others `paced`): blocks of BLOCK_TICKS tight
    ticks alternate with blocks of paced and warmed ones (the same load on all)."""
    session = settled(SessionConfig(robot=robot), trot)
    native, kernel = session.native_tick, session.controller.native_kernel
    clock, sleep = time.perf_counter, time.sleep
    spent = {kind: np.zeros((ticks, len(PACED_STAGES))) for kind in ("tight", "paced", "warmed")}
    done = dict.fromkeys(spent, 0)
    for block in itertools.cycle((("tight",), ("paced", "warmed"))):
        if min(done.values()) >= ticks:
            break
        deadline = clock()
        for i in range(BLOCK_TICKS):
            kind = block[i % len(block)]
            if done[kind] >= ticks:
                break
            warm = 0.0
            if kind != "tight":  # woken late, the periods lost are dropped: each tick sleeps
                deadline = max(deadline + PERIOD_S, clock() + PERIOD_S / 2)
                lead = SPIN_S + (WARM_LEAD_S if kind == "warmed" else 0.0)
                sleep(max(0.0, deadline - lead - clock()))
                if kind == "warmed":
                    warm = clock()
                    session.warm()
                    warm = clock() - warm
                while clock() < deadline:
                    pass
            start = clock()
            session.tick()
            whole = clock() - start
            call, control = native.call_us * 1e-6, native.control_us * 1e-6
            update, rows, method = kernel.seconds
            spent[kind][done[kind]] = (
                whole,
                call,
                whole - call,
                update,
                rows,
                method,
                control - update - rows - method,
                call - control,
                warm,
            )
            done[kind] += 1
    if session.tick_report()["tick"] != "native" or session.fell:
        raise SystemExit(f"the native tick did not run to the end: {session.tick_report()}")
    return {
        kind: dict(zip(PACED_STAGES, np.median(us, axis=0) * 1e6, strict=True))
        for kind, us in spent.items()
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="anymal")
    parser.add_argument("--trot", action="store_true", help="trot at 0.5 m/s instead of standing")
    parser.add_argument("--ticks", type=int, default=3000)
    parser.add_argument("--kernel", choices=("python", "native"), default="python")
    parser.add_argument("--whole", action="store_true", help="time Session.tick(), both paths")
    parser.add_argument(
        "--paced", action="store_true", help="the native tick's stages, tight and once per ms"
    )
    args = parser.parse_args()
    doing = "trotting" if args.trot else "standing"
    if args.paced:
        paced = measure_paced(args.robot, args.trot, args.ticks)
        print(
            f"{args.robot} {doing}, native server tick, median wall-clock µs over {args.ticks} "
            f"ticks of each kind:"
        )
        print(f"  {'stage':38s} {'tight':>7s} {'paced':>7s} {'warmed':>7s}")
        for stage in PACED_STAGES:
            tight, cold, warmed = (paced[kind][stage] for kind in ("tight", "paced", "warmed"))
            print(f"  {stage:38s} {tight:7.1f} {cold:7.1f} {warmed:7.1f}")
        return
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
