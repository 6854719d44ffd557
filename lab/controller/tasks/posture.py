"""Postural tasks: joint positions towards the reference posture (Raiola eq. 9), fixed or moving.

`moving_posture` is eq. 9 with a moving reference, q̈_a = kp (q_d − q_a) + kd (q̇_d − q̇_a), q̇_d
from the walking references (eqs. 30–31), zero for references without one. A swinging leg's
joints are left to `swing_feet`, which fixes them at a higher priority (posture rows on them only
steer the base's acceleration: docs/locomotion.md). A leg's rows are scaled by `posture_weight`
(its load ramp), so they fade in after touchdown and out before lift-off instead of switching.

`upper_body` is eq. 9 on the joints outside the legs alone, for a stack that holds a humanoid's
torso and arms apart from (above) its balance.
"""

from dataclasses import dataclass, field

import numpy as np

from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.references import References
from lab.controller.rows import PerContactSet, read_only, selection, zeros
from lab.controller.tasks.base import Task, TaskGains, TaskRows
from lab.controller.tasks.feet import has_swing, swinging


class PostureTask(Task):
    """Joint accelerations q̈_j = kp (q_ref − q_j) − kd q̇_j (Raiola eq. 9); the error is
    q_ref − q_j (rad, or m for prismatic joints)."""

    name = "posture"

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        e = refs.posture - robot.joint_positions
        b = self.gains.kp * e - self.gains.kd * robot.joint_velocities
        return TaskRows(selection(robot.nx, BASE_DOF, robot.nv), b, e)


def leg_joints(robot: RobotModel) -> list[np.ndarray]:
    """Actuated-joint indices of each contact's leg: the joints that move the contact point."""
    return [
        np.flatnonzero(np.any(np.abs(robot.Jc[s, BASE_DOF:]) > 1e-9, axis=0))
        for s in robot.force_slices
    ]


@dataclass(frozen=True)
class PostureRows:
    """The rows of the joints whose postural weight is positive, and the task's matrix."""

    joints: np.ndarray
    columns: np.ndarray  # of q̈_j in x
    A: np.ndarray  # (len(joints), nx): the weight w_j at column BASE_DOF + j of row j
    view: np.ndarray  # read-only A
    diagonal: tuple[np.ndarray, np.ndarray]  # (row, column) of each w_j in A

    @classmethod
    def of(cls, robot: RobotModel, on: np.ndarray) -> "PostureRows":
        """Rows for the joints flagged in `on`."""
        joints = np.flatnonzero(on)
        A = np.zeros((len(joints), robot.nx))
        columns = BASE_DOF + joints
        return cls(joints, columns, A, read_only(A), (np.arange(len(joints)), columns))

    def write(self, w: np.ndarray) -> None:
        """Put each joint's weight on its row."""
        self.A[self.diagonal] = w


@dataclass
class LegWeights:
    """Where each joint's postural weight comes from under one contact set.

    `weights` holds one slot per leg, then 1 (joints in no leg), then 0 (swinging legs); `slots`
    picks each joint's slot (the last leg that moves it), `swinging_slots` the same with the
    joints of the swinging legs on the zero slot.
    """

    weights: np.ndarray
    slots: np.ndarray
    swinging_slots: np.ndarray
    rows: dict[bytes, PostureRows] = field(default_factory=dict)  # by joints with rows

    @classmethod
    def of(cls, robot: RobotModel, legs: list[np.ndarray], active: np.ndarray) -> "LegWeights":
        """The slots of each joint for the legs `legs` under the contact flags `active`."""
        no_leg, swinging_slot = len(legs), len(legs) + 1
        weights = np.ones(len(legs) + 2)
        weights[swinging_slot] = 0.0
        slots = np.full(robot.na, no_leg)
        for i, leg in enumerate(legs):
            slots[leg] = i
        swinging_slots = slots.copy()
        for foot in np.flatnonzero(swinging(robot, active)):
            swinging_slots[legs[foot]] = swinging_slot
        return cls(weights, slots, swinging_slots)

    def rows_of(self, robot: RobotModel, weight: np.ndarray) -> PostureRows:
        """The rows of the joints with a positive weight (built once per set of such joints)."""
        on = weight > 0.0
        key = on.tobytes()
        rows = self.rows.get(key)
        if rows is None:
            rows = self.rows[key] = PostureRows.of(robot, on)
        return rows


class MovingPostureTask(Task):
    """Raiola eq. 9 with a moving reference and per-leg weights (module docstring); the error is
    q_d − q of the joints with rows (rad)."""

    name = "moving_posture"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._legs: list[np.ndarray] | None = None
        self._weights = PerContactSet(self._leg_weights)

    def _leg_weights(self, robot: RobotModel, active: np.ndarray) -> LegWeights:
        if self._legs is None:
            self._legs = leg_joints(robot)
        return LegWeights.of(robot, self._legs, active)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        legs = self._weights.get(robot, refs.contact_active)
        n_legs = len(legs.weights) - 2
        reference_velocity = zeros(robot.na)
        leg_weight: np.ndarray | float = 1.0
        if (walk := refs.walking) is not None:
            if len(walk.posture_velocity) == robot.na:
                reference_velocity = walk.posture_velocity
            if len(walk.posture_weight) == n_legs:
                leg_weight = walk.posture_weight
        # Each joint's weight: its leg's load ramp, 0 on a swinging leg, 1 outside the legs.
        legs.weights[:n_legs] = leg_weight
        weight = legs.weights[legs.swinging_slots if has_swing(refs) else legs.slots]
        rows = legs.rows_of(robot, weight)
        joints = rows.joints
        w = weight[joints]
        e = (refs.posture - robot.joint_positions)[joints]
        rows.write(w)
        de = reference_velocity[joints] - robot.v[rows.columns]
        return TaskRows(rows.view, w * (self.gains.kp * e + self.gains.kd * de), e)


class UpperBodyTask(Task):
    """Raiola eq. 9 on the joints that move no contact (a humanoid's torso or waist and arms, a
    quadruped's arm): q̈_j = kp (q_ref − q_j) − kd q̇_j; the error is q_ref − q_j of those
    joints (rad). No rows on a robot whose every joint is in a leg.

    The posture task of its own for the upper body that single support needs on a robot with
    free arms: Herzog's Sarcos was the lower body alone, its torso frozen (§4.1), and he expects
    a full humanoid to "allow for more hierarchy levels" (§6.1); sharing the posture weight
    of the legs, the arms are where the LQR's angular-momentum correction is cheapest
    (docs/performance.md, "Single support with free arms").
    """

    name = "upper_body"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._rows: PostureRows | None = None

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        if self._rows is None:  # at the first tick, as the kernel's
            on = np.ones(robot.na, dtype=bool)
            for leg in leg_joints(robot):
                on[leg] = False
            self._rows = PostureRows.of(robot, on)
            self._rows.write(np.ones(len(self._rows.joints)))
        rows = self._rows
        e = (refs.posture - robot.joint_positions)[rows.joints]
        b = self.gains.kp * e - self.gains.kd * robot.v[rows.columns]
        return TaskRows(rows.view, b, e)
