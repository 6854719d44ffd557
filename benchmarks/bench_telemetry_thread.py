"""Does building the telemetry and drawing messages on another thread pay under the GIL? (a
benchmark, issue 31 item 1.3)

    .venv/bin/python benchmarks/bench_telemetry_thread.py [--ticks 4000] [--rounds 2]

ANYmal trots at 0.5 m/s on native ticks; the loop thread ticks `--ticks` times back to back (the
busy part of the realtime loop, without its sleeps), and every 10th tick (100 Hz) the telemetry
and drawing messages are built either inline, after the tick, or on a second thread woken for
them. Prints, per way and round, wall-clock µs per tick (median, p99, max) and the wall time of
all ticks; and the thread CPU time of building one pair of messages.
"""

import argparse
import threading
import time

import numpy as np

from lab.world.session import Session, SessionConfig

WARM_UP_TICKS = 1500
EVERY = 10  # ticks between two messages: 100 Hz at 1 kHz


def trotting() -> Session:
    """ANYmal trotting at 0.5 m/s after the warm-up."""
    session = Session(SessionConfig(robot="anymal"))
    session.handle("gait", {"name": "trot"})
    session.handle("velocity", {"vx": 0.5})
    for _ in range(WARM_UP_TICKS):
        session.tick()
    return session


def build(session: Session) -> None:
    """One telemetry and one drawing message, as the loop publishes them."""
    session.telemetry()
    session.drawing_state()


def run(way: str, ticks: int) -> tuple[np.ndarray, float]:
    """Wall-clock s of each tick (message building included on the inline way) and in all."""
    session = trotting()
    wake, done = threading.Event(), threading.Event()

    def builder() -> None:
        while True:
            wake.wait()
            wake.clear()
            if done.is_set():
                return
            build(session)

    thread = threading.Thread(target=builder)
    thread.start()
    spent = np.zeros(ticks)
    start = time.perf_counter()
    for i in range(ticks):
        begin = time.perf_counter()
        session.tick()
        if i % EVERY == 0:
            if way == "inline":
                build(session)
            else:
                wake.set()
        spent[i] = time.perf_counter() - begin
    total = time.perf_counter() - start
    done.set()
    wake.set()
    thread.join()
    return spent, total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=4000)
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    session = trotting()
    cost = []
    for _ in range(300):
        session.tick()
        begin = time.thread_time()
        build(session)
        cost.append(time.thread_time() - begin)
    print(f"one telemetry + drawing message: median {np.median(cost) * 1e6:.0f} µs thread CPU")
    for round_ in range(args.rounds):
        for way in ("inline", "thread"):
            spent, total = run(way, args.ticks)
            us = spent * 1e6
            print(
                f"round {round_} {way:6s}: tick median {np.median(us):6.1f} p99 "
                f"{np.percentile(us, 99):8.1f} max {us.max():8.1f} µs; {args.ticks} ticks in "
                f"{total * 1e3:.0f} ms"
            )


if __name__ == "__main__":
    main()
