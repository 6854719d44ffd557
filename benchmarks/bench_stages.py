"""Where a session tick goes: median thread-CPU time of each stage (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_stages.py [--robot anymal] [--trot] [--ticks 3000]

Standing uses the robot's default stack; `--trot` trots at 0.5 m/s under Raiola's S3 (the stack
the gait command brings). Each stage is timed with `time.thread_time()` after 1.5 s of warm-up,
so time the thread spent descheduled does not count.
"""

import argparse
import time

import numpy as np

from lab.controller.hierarchy import METHODS
from lab.server.session import TOUCH_FORCE, Session, SessionConfig

WARM_UP_TICKS = 1500
STAGES = ("state", "touch", "model", "behaviour", "rows", "solve", "torques", "plant step")


def measure(robot: str, trot: bool, ticks: int) -> dict[str, float]:
    session = Session(SessionConfig(robot=robot))
    if trot:
        session.handle("gait", {"name": "trot"})
        session.handle("velocity", {"vx": 0.5})
    for _ in range(WARM_UP_TICKS):
        session.tick()
    controller, model, plant = session.controller, session.model, session.plant
    clock = time.thread_time
    spent = np.zeros((ticks, len(STAGES)))
    for i in range(ticks):
        marks = [clock()]
        q, v = plant.state()
        marks.append(clock())
        touching = plant.feet_touching(TOUCH_FORCE)
        marks.append(clock())
        model.update(q, v)
        marks.append(clock())
        session.behaviour.update(session.time, model, session.velocity, touching)
        marks.append(clock())
        problem = controller.build_problem()
        marks.append(clock())
        x = METHODS[controller.config.method](problem, controller.config.solver).x
        marks.append(clock())
        tau = model.joint_torques(x)
        marks.append(clock())
        plant.set_torques(tau)
        plant.step()
        marks.append(clock())
        spent[i] = np.diff(marks)
    return dict(zip(STAGES, np.median(spent, axis=0) * 1e6, strict=True))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", default="anymal")
    parser.add_argument("--trot", action="store_true", help="trot at 0.5 m/s instead of standing")
    parser.add_argument("--ticks", type=int, default=3000)
    args = parser.parse_args()
    medians = measure(args.robot, args.trot, args.ticks)
    doing = "trotting" if args.trot else "standing"
    print(f"{args.robot} {doing}, median µs of thread CPU time over {args.ticks} ticks:")
    for stage, us in medians.items():
        print(f"  {stage:11s} {us:6.0f}")
    print(f"  {'sum':11s} {sum(medians.values()):6.0f}")


if __name__ == "__main__":
    main()
