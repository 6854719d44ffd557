"""References: what the behaviour layer asks of the tasks this tick.

`References` holds what every behaviour sets; two kinds carry more, and say so: walking
references (`WalkReferences`: the swing feet's trajectories, the local surface normal under each
foot and the contact-force interpolation weight of each foot, Hutter 2014 §5.1.5–5.1.6; the
joint velocities the posture moves with, Raiola eqs. 30–31, and the weight of each leg's
postural rows) and a stance's (`SoleReferences`: a pose target per sole and the legs that swing
in joint space, Herzog 2016 §5.4). A task reads them through `walking` and `soles`, typed and
None for references without them (then flat, fully loaded ground and no sole targets), never by
asking for a class. The native kernel reads the three as one layout (cpp/references.hpp).
"""

from dataclasses import dataclass, field

import numpy as np

WORLD_UP = np.array([0.0, 0.0, 1.0])


@dataclass
class References:
    """Desired values the tasks track; the behaviour layer owns and updates them.

    Everything is in world axes; `posture` holds actuated joint positions in pinocchio order.
    """

    com: np.ndarray
    posture: np.ndarray
    base_height: float
    base_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    com_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # The CoM's reference acceleration (m/s²), fed forward by the momentum task (ḣ_ref, eq. 22).
    com_acceleration: np.ndarray = field(default_factory=lambda: np.zeros(3))
    base_angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    contact_active: np.ndarray = field(default_factory=lambda: np.ones(0, dtype=bool))
    # Per-contact upper bound on the normal force (N); a behaviour ramps it down before lift-off
    # and up after touchdown so that torques do not jump. Empty: the robot-wide bound applies.
    normal_force_max: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # Desired base linear velocity (world axes), for velocity tasks (Hutter Table 7).
    base_linear_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    # Hand targets of the `hands` task (tasks/hands.py), one row per hand the controller was given
    # (`set_hands`), in that order; empty: no targets, no rows. Position (m), its velocity and
    # acceleration fed forward (m/s, m/s²), rotation: in world axes, or for a hand whose
    # `hand_heading` flag is set, in the trunk's heading frame (tasks/hands.py: the base's
    # position, turned by its yaw; empty flags: every target in the world).
    hand_position: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    hand_velocity: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    hand_acceleration: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    hand_rotation: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    hand_heading: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    @property
    def walking(self) -> "WalkReferences | None":
        """These references' walking fields (`WalkReferences`), None when they carry none."""
        return None

    @property
    def soles(self) -> "SoleReferences | None":
        """These references' sole targets (`SoleReferences`), None when they carry none."""
        return None


@dataclass
class WalkReferences(References):
    """A walking behaviour's references (module docstring). Per-contact arrays, one row per
    contact in the robot's contact order (world axes)."""

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

    @property
    def walking(self) -> "WalkReferences":
        """These references: they carry the walking fields."""
        return self


@dataclass
class SoleReferences(References):
    """A stance's references (module docstring): a pose target per sole (world position, m, and
    rotation), read for the flat feet out of support (tasks/sole.py)."""

    sole_position: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    sole_rotation: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    # Per contact: its leg (out of support) follows the joint trajectory below, not its sole pose.
    leg_swinging: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    # Joint trajectory of the swinging legs (actuated joints, pinocchio order; rad, /s, /s²).
    leg_position: np.ndarray = field(default_factory=lambda: np.zeros(0))
    leg_velocity: np.ndarray = field(default_factory=lambda: np.zeros(0))
    leg_acceleration: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def soles(self) -> "SoleReferences":
        """These references: they carry the sole targets."""
        return self


def surface_normals(refs: References, n_contacts: int) -> np.ndarray:
    """The normals the references give, or world z under every foot (flat ground)."""
    walk = refs.walking
    if walk is not None and len(walk.surface_normal) == n_contacts:
        return walk.surface_normal
    return np.tile(WORLD_UP, (n_contacts, 1))
