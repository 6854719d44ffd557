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
"""

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from lab.world.session import Session

LOADED = 50.0  # N
INSIDE_TOL = 0.005  # m kept from the edge for "inside" (MuJoCo's contact points sit on the edge)
SETTLE = 0.005  # s


class SoleCopMetrics:
    def __init__(self, session: "Session") -> None:
        self.largest = np.zeros(2)
        self.loaded = self.inside = 0
        self.edge_time = 0.0
        self.start = session.time

    def update(self, session: "Session") -> None:
        model, plant = session.model, session.plant
        if session.time - self.start < SETTLE:
            return
        at_edge = False
        forces = plant.foot_forces()
        centres = plant.foot_pressure_centres()
        for i, contact in enumerate(model.contacts):
            if contact.kind != "flat" or np.linalg.norm(forces[i]) < LOADED:
                continue
            local = model.contact_rotations[i].T @ (centres[i] - model.contact_positions[i])
            half = np.array([contact.half_length, contact.half_width])
            self.largest = np.maximum(self.largest, np.abs(local[:2]) / half)
            self.loaded += 1
            inside = bool(np.all(np.abs(local[:2]) <= half - INSIDE_TOL))
            self.inside += inside
            at_edge |= not inside
        self.edge_time += at_edge * plant.timestep

    def result(self) -> dict[str, float]:
        return {
            "cop_sole_fraction_x_max": float(self.largest[0]),
            "cop_sole_fraction_y_max": float(self.largest[1]),
            "cop_inside_fraction": self.inside / max(self.loaded, 1),
            "cop_at_edge_s": self.edge_time,
        }
