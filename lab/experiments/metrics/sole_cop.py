"""The `sole_cop` metric (Herzog 2016 §5.2.3, Figs. 8–9): where the measured centre of pressure
of each loaded sole lies in it, while the ground under it moves.

Each tick, for each flat foot pressing with more than LOADED newtons, the CoP the sim measures
(`MujocoPlant.foot_pressure_centres`, its contact points weighted by their normal forces) is put
in the sole frame; its position along each axis over the sole's half size is the fraction of the
sole it uses (1 = on the edge). Reported: the largest fraction over the run, along x and along y,
the fraction of loaded sole-ticks whose CoP was inside the sole shrunk by INSIDE_TOL, and the
time (s) some loaded sole's CoP was not (a foot tipping about an edge, as at the balance board's
drop). The first SETTLE seconds are left out: on the first ticks the sim's contact points of a
sole just set on the ground are at its corners, before the contact solver spreads the load.
Per tick it works on Python floats, one matrix product a sole: with numpy calls on 2-vectors
it cost about as much as the whole native tick of a Herzog scenario (benchmarks/bench_scenarios.py,
docs/performance.md).
"""

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lab.world.session import Session

LOADED = 50.0  # N
INSIDE_TOL = 0.005  # m kept from the edge for "inside" (MuJoCo's contact points sit on the edge)
SETTLE = 0.005  # s


class SoleCopMetrics:
    def __init__(self, session: "Session") -> None:
        self.largest_x = self.largest_y = 0.0
        self.loaded = self.inside = 0
        self.edge_time = 0.0
        self.start = session.time
        # (contact index, half length, half width) of each flat sole
        self.soles = [
            (i, c.half_length, c.half_width)
            for i, c in enumerate(session.model.contacts)
            if c.kind == "flat"
        ]

    def update(self, session: "Session") -> None:
        model, plant = session.model, session.plant
        if session.time - self.start < SETTLE:
            return
        at_edge = False
        forces = plant.foot_forces()
        centres = plant.foot_pressure_centres()
        for i, half_x, half_y in self.soles:
            force = forces[i]
            if math.sqrt(force @ force) < LOADED:  # as np.linalg.norm computes it
                continue
            local = model.contact_rotations[i].T @ (centres[i] - model.contact_positions[i])
            x, y = abs(float(local[0])), abs(float(local[1]))
            self.largest_x = max(self.largest_x, x / half_x)
            self.largest_y = max(self.largest_y, y / half_y)
            self.loaded += 1
            inside = x <= half_x - INSIDE_TOL and y <= half_y - INSIDE_TOL
            self.inside += inside
            at_edge |= not inside
        self.edge_time += at_edge * plant.timestep

    def result(self) -> dict[str, float]:
        return {
            "cop_sole_fraction_x_max": self.largest_x,
            "cop_sole_fraction_y_max": self.largest_y,
            "cop_inside_fraction": self.inside / max(self.loaded, 1),
            "cop_at_edge_s": self.edge_time,
        }
