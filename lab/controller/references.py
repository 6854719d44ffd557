"""References: what the behaviour layer asks of the tasks this tick."""

from dataclasses import dataclass, field

import numpy as np


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
