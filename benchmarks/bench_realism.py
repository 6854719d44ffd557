"""The realism layer's cost per tick (docs/realism.md): the C++ layer alone (lab._kernel's
RealismLayer, what the native tick will call) and the Python reference, ideal against every
knob on (`harsh` with the SEA), and the whole session tick (ANYmal standing, native controller
and plant) with realism ideal against typical, its layer in C++ (the session's default when
lab._kernel is built) and in Python.

    .venv/bin/python benchmarks/bench_realism.py [--ticks N]

Prints median and p99 in µs per tick; run it on a quiet machine and quote `uptime` beside it.
"""

import argparse
import time
from collections.abc import Callable

import numpy as np

from lab import _kernel
from lab.realism.knobs import knobs_from, preset
from lab.realism.layer import RealismLayer, realism_layer
from lab.world.session import Session, SessionConfig

NA, DT = 12, 1e-3


def _times(step: Callable[[], None], ticks: int) -> np.ndarray:
    out = np.empty(ticks)
    for i in range(ticks):
        start = time.perf_counter()
        step()
        out[i] = (time.perf_counter() - start) * 1e6
    return out


def _row(label: str, us: np.ndarray) -> float:
    median = float(np.median(us))
    print(f"{label:<44} median {median:8.2f} µs   p99 {np.percentile(us, 99):8.2f} µs")
    return median


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=5000)
    ticks = parser.parse_args().ticks
    every = knobs_from(preset("harsh", "anymal"), {"actuator": "sea", "sea_kp": 1800.0})
    q = np.concatenate(([0, 0, 0.5, 0, 0, 0, 1.0], np.zeros(NA)))
    v, tau = np.zeros(6 + NA), np.ones(NA)
    for kind, make in (("C++", _kernel.RealismLayer), ("Python", RealismLayer)):
        layer = make(every.values() if kind == "C++" else every, NA, DT)
        layer.reset(q, tau)

        def step(layer=layer) -> None:
            layer.measure(q, v)
            layer.actuate(tau, q, v)

        _row(f"{kind} layer, every knob on (measure + actuate)", _times(step, ticks))
    medians = {}
    for name, native in (("ideal", True), ("typical", True), ("typical", False)):
        knobs = preset(name, "anymal")
        session = Session(SessionConfig(robot="anymal", realism=knobs))
        session.realism = realism_layer(knobs, NA, DT, native=native)
        session.realism.reset(session.robot.q_standing)
        for _ in range(200):
            session.tick()
        label = f"session tick, ANYmal standing, {name} ({session.realism.kernel} layer)"
        medians[label] = _row(label, _times(session.tick, ticks))
    ideal = medians[next(iter(medians))]
    for label, median in list(medians.items())[1:]:
        print(f"{label} / ideal: {median / ideal:.3f}")


if __name__ == "__main__":
    main()
