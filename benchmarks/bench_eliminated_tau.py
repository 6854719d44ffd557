"""Herzog 2016 Fig. 5: the QP cascade with τ eliminated (Newton–Euler rows only, eq. 13) against
the same cascade over the full equations of motion (a benchmark, not a test).

    .venv/bin/python benchmarks/bench_eliminated_tau.py [--ticks 300] [--stance left]

Talos balances under Herzog's Table 2 (double support), or with `--stance left|right` under
Table 4 on one sole, the other lifted (§5.4: the stance transition runs first under the preset's
QP cascade, STANCE_TICKS). The `nullspace` method is Herzog's
cascade (a QP per level, each solved in the null space of those above, eq. 8). Each tick the one
problem the
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
from lab.world.session import Session, SessionConfig

WARM_UP_TICKS = 300
# The stance transition (behaviours/stance.py): the CoG over the sole in 1 s, the other sole
# unloaded in 0.5 s and lifted 10 cm in 1 s, then 0.5 s to settle.
STANCE_TICKS = 3000


def measure(ticks: int, stance: str = "double") -> dict[str, tuple[float, float]]:
    """{formulation: (median µs, largest µs)} of the nullspace cascade's solve on Talos, on both
    soles (Table 2) or on the `stance` sole (Table 4)."""
    session = Session(SessionConfig(robot="talos", kernel="python"))
    preset = "herzog_table2" if stance == "double" else "herzog_table4"
    assert session.handle("stack", {"preset": preset})["ok"]
    if stance != "double":
        assert session.handle("stance", {"side": stance})["ok"]
        for _ in range(STANCE_TICKS):
            session.tick()
        if session.fell or session.controller.references.contact_active.sum() != 1:
            raise SystemExit(f"Talos did not get onto its {stance} sole")
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
    parser.add_argument("--stance", choices=("double", "left", "right"), default="double")
    args = parser.parse_args()
    result = measure(args.ticks, args.stance)
    for formulation, (median, largest) in result.items():
        print(f"{formulation:10s} median {median:8.0f} µs   largest {largest:8.0f} µs")
    (eliminated, _), (full, _) = result["qdd_force"], result["full"]
    print(f"τ eliminated saves {100 * (1 - eliminated / full):.0f} % of the median time")
    print(f"and {100 * (1 - result['qdd_force'][1] / result['full'][1]):.0f} % of the largest")


if __name__ == "__main__":
    main()
