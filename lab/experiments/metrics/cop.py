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
    def __init__(self, session: "Session") -> None:
        self.ground = session.model.contact_positions[:, 2].copy()
        self.ticks = self.binding = 0
        self.tilt = self.rise = 0.0

    def update(self, session: "Session") -> None:
        model, refs = session.model, session.controller.references
        self.ticks += 1
        at_bound = False
        for i, (contact, rows) in enumerate(zip(model.contacts, model.force_slices, strict=True)):
            if contact.kind != "flat" or not refs.contact_active[i]:
                continue
            _, _, fz, tx, ty, _ = session.forces[rows]
            if fz > LOADED:
                half = (1.0 - INNER_COP_MARGIN) * np.array(
                    [contact.half_length, contact.half_width]
                )
                cop = np.array([-ty, tx]) / fz
                at_bound |= bool(np.any(np.abs(cop) > half - BOUND_TOL))
            normal_z = np.clip(model.contact_rotations[i][2, 2], -1.0, 1.0)
            self.tilt = max(self.tilt, float(np.arccos(normal_z)))
            self.rise = max(self.rise, float(model.contact_positions[i, 2] - self.ground[i]))
        self.binding += at_bound

    def result(self) -> dict[str, float]:
        return {
            "cop_at_bound_fraction": self.binding / max(self.ticks, 1),
            "max_sole_tilt_rad": self.tilt,
            "max_sole_rise_m": self.rise,
        }
