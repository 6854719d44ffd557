"""Both kernels on Herzog's and Kim's stacks, alternated in one session (a benchmark).

    .venv/bin/python benchmarks/bench_kernel_stacks.py [--blocks 4] [--ticks 300]

Three sessions: Talos under herzog_table2 with the `lqr_talos` momentum law, standing; Talos
under herzog_table4 on its left sole with the right one lifted (the `stance` command, `lqr`);
Bolt on its default stack (internal force sensed from the feet), cascade. In each, blocks of
`--ticks` session ticks alternate between the native and the Python kernel (the `hierarchy`
command), so that both see the same machine load. Per session it prints, in µs, the median and
the minimum of the native kernel's own time (update and solve, `Kernel.seconds`) and of
`session.tick()` on each kernel, and their ratio.
"""

import argparse
import time

import numpy as np

from lab.world.session import Session, SessionConfig

WARM_UP_TICKS = 5  # of each block, after a kernel switch


def alternate(session: Session, blocks: int, ticks: int) -> str:
    """The summary line of `blocks` pairs of native and Python blocks."""
    tick: dict[str, list[float]] = {"native": [], "python": []}
    in_kernel: list[float] = []
    for _ in range(blocks):
        for kernel in tick:
            assert session.handle("hierarchy", {"kernel": kernel})["ok"]
            for i in range(ticks):
                start = time.perf_counter()
                session.tick()
                seconds = time.perf_counter() - start
                if i < WARM_UP_TICKS:
                    continue
                tick[kernel].append(seconds)
                if kernel == "native":
                    in_kernel.append(sum(session.controller.kernel_seconds))
            telemetry = session.telemetry()
            assert telemetry["kernel"] == kernel, telemetry["kernel_note"]
    assert not session.fell and session.qp_failures == 0
    native, python = (np.array(tick[k]) * 1e6 for k in ("native", "python"))
    own = np.array(in_kernel) * 1e6
    return (
        f"in-kernel p50 {np.median(own):.0f} (min {own.min():.0f}) | tick native p50 "
        f"{np.median(native):.0f} (min {native.min():.0f}), python p50 {np.median(python):.0f} "
        f"(min {python.min():.0f}) | ratio p50 {np.median(native) / np.median(python):.2f} "
        f"(min {native.min() / python.min():.2f})"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blocks", type=int, default=4)
    parser.add_argument("--ticks", type=int, default=300)
    args = parser.parse_args()

    session = Session(SessionConfig(robot="talos"))
    assert session.handle("stack", {"preset": "herzog_table2"})["ok"]
    assert session.handle("momentum", {"mode": "lqr_talos"})["ok"]
    for _ in range(200):
        session.tick()
    print("talos herzog_table2 lqr_talos, standing:", alternate(session, args.blocks, args.ticks))

    session = Session(SessionConfig(robot="talos"))
    assert session.handle("stance", {"side": "left"})["ok"]
    assert session.handle("momentum", {"mode": "lqr"})["ok"]
    for _ in range(3000):  # shift, unload, lift (behaviours/stance.py)
        session.tick()
    assert list(session.controller.references.contact_active) == [True, False]
    print("talos herzog_table4 lqr, one sole:", alternate(session, args.blocks, args.ticks))

    session = Session(SessionConfig(robot="bolt"))
    for _ in range(200):
        session.tick()
    print("bolt default stack, cascade:", alternate(session, args.blocks, args.ticks))


if __name__ == "__main__":
    main()
