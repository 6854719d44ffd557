"""References of a walking behaviour that the standing ones do not have.

`WalkReferences` extends `References` with what the static walk asks of its tasks: the swing
feet's trajectories, the local surface normal under each foot, and the contact-force
interpolation weight of each foot (Hutter 2014 §5.1.5–5.1.6), and the joint velocities the
posture moves with (Raiola eqs. 30–31) and the weight of each leg's postural rows. Tasks that need
these fields read
them when the references carry them and fall back to flat, fully loaded ground otherwise.
"""

from dataclasses import dataclass, field

import numpy as np

from lab.controller.references import References

WORLD_UP = np.array([0.0, 0.0, 1.0])


@dataclass
class WalkReferences(References):
    """Per-contact arrays, one row per contact in the robot's contact order (world axes)."""

    foot_position: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    foot_velocity: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    foot_acceleration: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    # Unit normal of the ground under each foot.
    surface_normal: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    # w ∈ [0, 1] scaling the optimal force of a foot being loaded or unloaded; NaN: not changing.
    force_weight: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # Joint velocity reference q̇_d of the postural task (Raiola eq. 9); empty: zero.
    posture_velocity: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # Feet the swing_feet task moves; empty: those out of contact. A foot in a contact transition
    # (Kim 2016 §III-F) keeps tracking its reference while its reaction force ramps.
    swing_tracked: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    # w ∈ [0, 1] weighting the postural rows of each contact's leg (the leg's load ramp); empty: 1.
    posture_weight: np.ndarray = field(default_factory=lambda: np.zeros(0))


def surface_normals(refs: References, n_contacts: int) -> np.ndarray:
    """The normals the references give, or world z under every foot (flat ground)."""
    if isinstance(refs, WalkReferences) and len(refs.surface_normal) == n_contacts:
        return refs.surface_normal
    return np.tile(WORLD_UP, (n_contacts, 1))
