"""What typing a message as a lab.protocol struct would cost the loop (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_protocol.py [--robot anymal] [--reps 2000]

On a running session (after 1 s of warm-up): the telemetry message and the drawing state built
as the loop builds them (dicts, lab/world/telemetry.py), their encoding to JSON, and what a
struct would add: the dict converted (validated) into its `Telemetry` / `State` struct, and the
struct encoded. Also a command's decoding: `parse_command` on a push payload, as the intake
thread runs it. Prints median and p99 of each in µs. The loop builds dicts and the tests hold
them to the structs (docs/protocol.md, "Schemas"): this says what the other choice costs.
"""

import argparse
import time
from collections.abc import Callable

import msgspec
import numpy as np

from lab.protocol import parse_command
from lab.protocol.messages import State, Telemetry
from lab.runtime.transport import encode
from lab.world.session import Session, SessionConfig

WARM_UP_TICKS = 1000


def timed(job: Callable[[], object], reps: int) -> tuple[float, float]:
    """Median and p99 of `job`'s wall time over `reps` calls, µs."""
    times = np.empty(reps)
    for i in range(reps):
        start = time.perf_counter()
        job()
        times[i] = time.perf_counter() - start
    median, p99 = np.percentile(times * 1e6, [50, 99])
    return float(median), float(p99)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robot", default="anymal")
    parser.add_argument("--reps", type=int, default=2000)
    args = parser.parse_args()
    session = Session(SessionConfig(robot=args.robot))
    for _ in range(WARM_UP_TICKS):
        session.tick()
    telemetry, state = session.telemetry(), session.drawing_state()
    plain_telemetry = msgspec.json.decode(encode(telemetry))  # JSON types, as a client has them
    plain_state = msgspec.json.decode(encode(state))
    typed_telemetry = msgspec.convert(plain_telemetry, Telemetry)
    typed_state = msgspec.convert(plain_state, State)
    push = {"body": "base", "force": [0.0, 80.0, 0.0], "duration": 0.2}
    jobs: dict[str, Callable[[], object]] = {
        "telemetry: build the dict": session.telemetry,
        "telemetry: encode the dict": lambda: encode(telemetry),
        "telemetry: dict -> Telemetry struct": lambda: msgspec.convert(plain_telemetry, Telemetry),
        "telemetry: encode the struct": lambda: msgspec.json.encode(typed_telemetry),
        "state: build the dict": session.drawing_state,
        "state: encode the dict": lambda: encode(state),
        "state: dict -> State struct": lambda: msgspec.convert(plain_state, State),
        "state: encode the struct": lambda: msgspec.json.encode(typed_state),
        "command: parse_command(push)": lambda: parse_command("push", push),
    }
    print(f"{args.robot}, {args.reps} repetitions: median / p99 µs")
    for name, job in jobs.items():
        median, p99 = timed(job, args.reps)
        print(f"  {name:40s} {median:8.1f} {p99:8.1f}")


if __name__ == "__main__":
    main()
