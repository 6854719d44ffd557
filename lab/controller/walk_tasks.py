"""Motion tasks of the static-walk experiments (Hutter 2014 §5.1): swing feet and planar CoM.

- `swing_feet`: each point foot out of support tracks the behaviour's swing trajectory,
  J_i q̈ + J̇_i v = a_ref + kp (p_ref − p) + kd (v_ref − v), world axes. Flat feet and references
  without foot trajectories give no rows.
- `com_xy`: the horizontal CoM alone (Table 6, P3), so that body height can sit at another
  priority (`base_height`).
- `moving_posture`: Raiola's postural task eq. 9 with a moving reference,
  q̈_a = kp (q_d − q_a) + kd (q̇_d − q̇_a), q̇_d from the walking references (eqs. 30–31), zero
  for references without one. A swinging leg's joints are left to `swing_feet`, which fixes
  them at a higher priority: posture rows on them only steer the base's acceleration (under S3,
  ANYmal's 0.5 m/s trot ran at 0.62 m/s with ±0.25 m/s of lateral sway; without them at
  0.525 m/s and ±0.06 m/s). A leg's rows are scaled by `posture_weight` (its load ramp), so they
  fade in after touchdown and out before lift-off instead of switching: at touchdown the leg's
  joints still move at the swing's speed, and a row switching on with kd (q̇_d − q̇) stepped
  ANYmal's stance normal forces by 207 N in one tick.
"""

from dataclasses import dataclass, field

import numpy as np

from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.references import References
from lab.controller.tasks import (
    TASK_TYPES,
    ComTask,
    JacobianRows,
    PerContactSet,
    Task,
    TaskGains,
    no_rows,
    read_only,
    zeros,
)
from lab.controller.walk_references import WalkReferences


@dataclass(frozen=True)
class SwingRows:
    """The swinging point feet of one contact set and the task's rows for them."""

    coords: np.ndarray  # their entries in the flattened (n_contacts, 3) per-foot arrays
    jacobian: JacobianRows

    @classmethod
    def of(cls, robot: RobotModel, active: np.ndarray) -> "SwingRows":
        swinging = _swinging(robot, active)
        coords = (3 * np.flatnonzero(swinging)[:, None] + np.arange(3)).ravel()
        return cls(coords, JacobianRows.of(robot, swinging))


class SwingFeetTask(Task):
    name = "swing_feet"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._swing = PerContactSet(SwingRows.of)

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        swing = self._swing.get(robot, refs.contact_active) if _has_swing(refs) else None
        if swing is None or not len(swing.coords):
            self.error = zeros(0)
            return no_rows(robot.nx)
        feet, jacobian = swing.coords, swing.jacobian
        e = refs.foot_position.take(feet) - robot.contact_positions.take(feet)
        de = refs.foot_velocity.take(feet) - jacobian.write(robot).dot(robot.v)
        b = (
            refs.foot_acceleration.take(feet)
            + self.gains.kp * e
            + self.gains.kd * de
            - robot.Jc_dot_v[jacobian.index]
        )
        self.error = e
        return jacobian.view, b


class ComXYTask(ComTask):
    name = "com_xy"

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        A, b = super().rows(robot, refs)
        self.error = self.error[:2]
        return A[:2], b[:2]


def leg_joints(robot: RobotModel) -> list[np.ndarray]:
    """Actuated-joint indices of each contact's leg: the joints that move the contact point."""
    return [
        np.flatnonzero(np.any(np.abs(robot.Jc[s, BASE_DOF:]) > 1e-9, axis=0))
        for s in robot.force_slices
    ]


def _has_swing(refs: References) -> bool:
    """Whether the references give the feet swing trajectories (walking references do)."""
    return isinstance(refs, WalkReferences) and len(refs.foot_position) > 0


def _swinging(robot: RobotModel, active: np.ndarray) -> np.ndarray:
    """Flags of the point feet out of contact: the `swing_feet` task's feet when the references
    have swing trajectories."""
    point = np.array([contact.kind == "point" for contact in robot.contacts])
    return point & ~np.asarray(active, dtype=bool)


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
        joints = np.flatnonzero(on)
        A = np.zeros((len(joints), robot.nx))
        columns = BASE_DOF + joints
        return cls(joints, columns, A, read_only(A), (np.arange(len(joints)), columns))

    def write(self, w: np.ndarray) -> None:
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
        no_leg, swinging = len(legs), len(legs) + 1
        weights = np.ones(len(legs) + 2)
        weights[swinging] = 0.0
        slots = np.full(robot.na, no_leg)
        for i, leg in enumerate(legs):
            slots[leg] = i
        swinging_slots = slots.copy()
        for i in np.flatnonzero(_swinging(robot, active)):
            swinging_slots[legs[i]] = swinging
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
    name = "moving_posture"

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._legs: list[np.ndarray] | None = None
        self._weights = PerContactSet(self._leg_weights)

    def _leg_weights(self, robot: RobotModel, active: np.ndarray) -> LegWeights:
        if self._legs is None:
            self._legs = leg_joints(robot)
        return LegWeights.of(robot, self._legs, active)

    def rows(self, robot: RobotModel, refs: References) -> tuple[np.ndarray, np.ndarray]:
        legs = self._weights.get(robot, refs.contact_active)
        n_legs = len(legs.weights) - 2
        reference_velocity = zeros(robot.na)
        leg_weight: np.ndarray | float = 1.0
        if isinstance(refs, WalkReferences):
            if len(refs.posture_velocity) == robot.na:
                reference_velocity = refs.posture_velocity
            if len(refs.posture_weight) == n_legs:
                leg_weight = refs.posture_weight
        # Each joint's weight: its leg's load ramp, 0 on a swinging leg, 1 outside the legs.
        legs.weights[:n_legs] = leg_weight
        weight = legs.weights[legs.swinging_slots if _has_swing(refs) else legs.slots]
        rows = legs.rows_of(robot, weight)
        joints = rows.joints
        w = weight[joints]
        e = (refs.posture - robot.q[7:])[joints]
        self.error = e
        rows.write(w)
        de = reference_velocity[joints] - robot.v[rows.columns]
        return rows.view, w * (self.gains.kp * e + self.gains.kd * de)


for _task in (SwingFeetTask, ComXYTask, MovingPostureTask):
    TASK_TYPES[_task.name] = _task
