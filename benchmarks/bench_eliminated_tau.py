"""Herzog 2016 Fig. 5: the QP cascade with τ eliminated (Newton–Euler rows only, eq. 13) against
the same cascade over the full equations of motion (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_eliminated_tau.py [--ticks 300]

Talos balances under Herzog's Table 2 (double support). The `nullspace` method is Herzog's
cascade (a QP per level, each solved in the null space of those above, eq. 8); single support
is not measured: under Table 4 the Python active set stops at its cap during the stance
transition and Talos falls. Each tick the one problem the
controller built is solved twice, with the `qdd_force` formulation (z = [q̈, F], the 6 floating-
base rows of the equations of motion on top: τ eliminated, Herzog §2.3) and with `full`
(z = [q̈, τ, F] under all of M q̈ + h = Sᵀ τ + J_sᵀ F), and each solve is timed with
`time.thread_time()` (time the thread spent descheduled does not count). The sim runs on the
`qdd_force` solution; the two solves take turns going first. Reported: the median and largest
time of each and the saving.
"""

import argparse
import time
from dataclasses import replace

import numpy as np

from lab.controller.hierarchy import METHODS
from lab.server.session import Session, SessionConfig

WARM_UP_TICKS = 300


def measure(ticks: int) -> dict[str, tuple[float, float]]:
    """{formulation: (median µs, largest µs)} of the nullspace cascade's solve on Talos."""
    session = Session(SessionConfig(robot="talos", kernel="python"))
    assert session.handle("stack", {"preset": "herzog_table2"})["ok"]
    assert session.handle("hierarchy", {"method": "nullspace", "formulation": "qdd_force"})["ok"]
    for _ in range(WARM_UP_TICKS):
        session.tick()
    controller, clock = session.controller, time.thread_time
    solve = METHODS["nullspace"]
    spent: dict[str, list[float]] = {"qdd_force": [], "full": []}
    for tick in range(ticks):
        session.model.update(*session.plant.state())
        problem = controller.build_problem()
        for formulation in sorted(spent, reverse=tick % 2 == 1):  # each first every other tick
            start = clock()
            solve(replace(problem, formulation=formulation), controller.config.solver)
            spent[formulation].append(clock() - start)
        session.tick()
    if session.fell:
        raise SystemExit("Talos fell during the benchmark")
    return {k: (float(np.median(v)) * 1e6, float(np.max(v)) * 1e6) for k, v in spent.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=300)
    args = parser.parse_args()
    result = measure(args.ticks)
    for formulation, (median, largest) in result.items():
        print(f"{formulation:10s} median {median:8.0f} µs   largest {largest:8.0f} µs")
    (eliminated, _), (full, _) = result["qdd_force"], result["full"]
    print(f"τ eliminated saves {100 * (1 - eliminated / full):.0f} % of the median time")
    print(f"and {100 * (1 - result['qdd_force'][1] / result['full'][1]):.0f} % of the largest")


if __name__ == "__main__":
    main()
