"""Where a robot switch keeps the GIL (not a test): each step of a switch's build, timed on a
thread while the main thread wakes every 0.5 ms, as the loop does; the longest the main
thread waited during a step is about the longest that step kept the GIL from it (above the
machine's own wake-up noise: the `idle` line, nothing running beside), and a step that is one
C call keeping the GIL keeps it for its CPU time at least (longer when the machine preempts it).

Two ways to build the same switch, in one run:
- `in-process`: `build_parts` as a session builds itself, the robot's URDF and MuJoCo's compile
  included (round 12's switch, on a thread beside the loop);
- `worker`: as `lab serve` switches (lab/runtime/switch.py): the robot and MuJoCo's model from
  the worker process (`world (worker builds)`: the thread waits, GIL free) or its cache
  (`world (cached)`), then the rest of `build_parts`; then the swap on the loop (`install`),
  the new robot's first ticks and the old parts freed.

    .venv/bin/python benchmarks/bench_switch_steps.py [--robot solo12] [--scene flat]
"""

import argparse
import contextlib
import os
import sys
import threading
import time
from collections.abc import Callable, Iterator

import lab.world.compiled as compiled
import lab.world.session_parts as session_module
from lab.runtime.world_cache import WorldCache
from lab.world.session import Session, SessionConfig
from lab.world.session_parts import build_parts

PROBE_S = 5e-4  # the main thread's sleep between wake-ups
# What build_parts calls, by name in lab.world.session_parts, and compile_world's, in
# lab.world.compiled
SESSION_STEPS = (
    "MujocoPlant",
    "perturbed_model",
    "RobotModel",
    "NativeController",
    "FramePlacements",
    "NativeTick",
    "realism_layer",
)
COMPILE_STEPS = ("load_description", "build_robot", "build_spec")


class Steps:
    """Named steps with their start and end (perf_counter, s), recorded from any thread."""

    def __init__(self) -> None:
        self.spans: list[tuple[str, float, float, float]] = []  # name, start, end, thread CPU

    def timed(self, name: str, call: Callable) -> Callable:
        def wrapper(*args: object, **kwargs: object) -> object:
            start, cpu = time.perf_counter(), time.thread_time()
            try:
                return call(*args, **kwargs)
            finally:
                end = time.perf_counter()
                self.spans.append((name, start, end, time.thread_time() - cpu))

        return wrapper

    @contextlib.contextmanager
    def patched(self) -> Iterator[None]:
        """build_parts' and compile_world's calls timed by name (MjSpec.compile among them)."""
        saved = []
        for module, names in ((session_module, SESSION_STEPS), (compiled, COMPILE_STEPS)):
            for name in names:
                saved.append((module, name, getattr(module, name)))
                setattr(module, name, self.timed(name, getattr(module, name)))
        timed_spec, timed = compiled.build_spec, self.timed

        class _Spec:  # the spec's compile, timed
            def __init__(self, spec: object) -> None:
                self.compile = timed("MjSpec.compile", spec.compile)

        compiled.build_spec = lambda *args: _Spec(timed_spec(*args))
        try:
            yield
        finally:
            for module, name, value in saved:
                setattr(module, name, value)


def probe(run: Callable[[], None]) -> list[tuple[float, float]]:
    """Run `run` on a thread while this one wakes every PROBE_S; (wake-up time, gap) each."""
    done = threading.Event()

    def target() -> None:
        try:
            run()
        finally:
            done.set()

    gaps, last = [], time.perf_counter()
    thread = threading.Thread(target=target)
    thread.start()
    while not done.is_set():
        time.sleep(PROBE_S)
        now = time.perf_counter()
        gaps.append((now, now - last))
        last = now
    thread.join()
    return gaps


def report(title: str, steps: Steps, gaps: list[tuple[float, float]], cpu: float) -> None:
    """Each step: wall time, the thread's CPU time (a C call that keeps the GIL keeps it this
    long at least), the main thread's longest wait; `cpu`: the process's CPU time meanwhile,
    every thread (MuJoCo's compile runs threads of its own)."""
    print(f"{title}: the sim process's CPU time {1e3 * cpu:.0f} ms (all its threads)")
    for name, start, end, thread_cpu in sorted(steps.spans, key=lambda span: span[1]):
        # a wake-up whose sleep overlapped the step
        inside = [gap for t, gap in gaps if t >= start and t - gap <= end]
        longest = max(inside, default=0.0)
        print(
            f"  {name:34s} {1e3 * (end - start):8.1f} ms, CPU {1e3 * thread_cpu:7.1f} ms, "
            f"longest wait {1e3 * longest:6.1f} ms"
        )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", default="solo12")
    parser.add_argument("--scene", default="flat")
    args = parser.parse_args()
    sys.setswitchinterval(2e-4)  # the loop's (LoopConfig.switch_interval_s)
    config = SessionConfig(robot=args.robot, scene=args.scene)
    session = Session(SessionConfig(robot="bolt"))  # imports done, files read once
    build_parts(config)
    print(f"load average {os.getloadavg()[0]:.1f}; {args.robot} in {args.scene}")
    idle = probe(lambda: time.sleep(0.5))
    print(f"idle: longest wait {1e3 * max(gap for _, gap in idle):.1f} ms")

    steps, cpu = Steps(), time.process_time()
    with steps.patched():
        gaps = probe(lambda: steps.timed("build_parts (whole)", build_parts)(config))
    report("in-process", steps, gaps, time.process_time() - cpu)

    cache, steps = WorldCache(), Steps()
    cache.worker_pid()  # the worker started: its start-up is not a switch's

    def switch() -> None:
        for label in ("world (worker builds)", "world (cached)"):
            world = steps.timed(label, cache.world)
            parts = steps.timed("build_parts (whole)", build_parts)(config, world=world)
        old = steps.timed("install (on the loop)", session.install)(parts)
        for i in range(2):
            steps.timed(f"tick {i + 1} of the new robot", session.tick)()
        steps.timed("old parts freed", old.__dict__.clear)()

    try:
        cpu = time.process_time()
        with steps.patched():
            gaps = probe(switch)
        cpu = time.process_time() - cpu
    finally:
        cache.close()
    report("worker", steps, gaps, cpu)
    return 0


if __name__ == "__main__":
    sys.exit(main())
