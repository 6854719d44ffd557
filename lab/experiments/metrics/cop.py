"""The `cop_binding` metric (Herzog 2016 Fig. 10): how often the CoP constraint binds, and whether
the soles stay flat meanwhile.

Each tick, for each sole in support carrying load, the planned CoP (−τ_y/f_z, τ_x/f_z in the
sole frame, from the controller's contact wrench) is at its bound when it is within BOUND_TOL of
the `cop_inner` rectangle's edge. Reported: the fraction of ticks with a CoP at its bound, the
largest tilt of a sole in support (rad, its normal against the vertical) and the largest rise
of one above where it started (m), both measured on the robot's state.
"""

from typing import TYPE_CHECKING

import numpy as np

from lab.controller.constraints import INNER_COP_MARGIN

if TYPE_CHECKING:
    from lab.world.session import Session

BOUND_TOL = 1e-3  # m
LOADED = 50.0  # N, a sole carrying less is not counted


class CopBindingMetrics:
    """Fed after every tick: Python floats, no numpy call on a 2-vector (one per sole a tick cost
    as much as a tenth of the native tick); the largest tilt is taken as arccos of the smallest
    normal z, arccos being decreasing."""

    def __init__(self, session: "Session") -> None:
        model = session.model
        self.ground = model.contact_positions[:, 2].tolist()
        inner = 1.0 - INNER_COP_MARGIN
        # (index, its rows of F, where its CoP is at its bound along the sole's x and y) per
        # flat sole
        self.soles = [
            (i, rows, inner * c.half_length - BOUND_TOL, inner * c.half_width - BOUND_TOL)
            for i, (c, rows) in enumerate(zip(model.contacts, model.force_slices, strict=True))
            if c.kind == "flat"
        ]
        self.ticks = self.binding = 0
        self.lowest_normal_z = 1.0  # of a sole in support: its tilt is arccos of it
        self.rise = 0.0

    def update(self, session: "Session") -> None:
        model, active = session.model, session.controller.references.contact_active
        self.ticks += 1
        at_bound = False
        forces = session.forces
        for i, rows, bound_x, bound_y in self.soles:
            if not active[i]:
                continue
            _, _, fz, tx, ty, _ = forces[rows].tolist()
            if fz > LOADED:
                at_bound = at_bound or abs(-ty / fz) > bound_x or abs(tx / fz) > bound_y
            normal_z = min(max(float(model.contact_rotations[i][2, 2]), -1.0), 1.0)
            self.lowest_normal_z = min(self.lowest_normal_z, normal_z)
            self.rise = max(self.rise, float(model.contact_positions[i, 2]) - self.ground[i])
        self.binding += at_bound

    def result(self) -> dict[str, float]:
        return {
            "cop_at_bound_fraction": self.binding / max(self.ticks, 1),
            "max_sole_tilt_rad": float(np.arccos(self.lowest_normal_z)),
            "max_sole_rise_m": self.rise,
        }
