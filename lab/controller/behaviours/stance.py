"""Stance: a biped stands on both soles or on one, switching as Herzog 2016 §5.4 does.

From double to single support on `side`, in three phases:
1. shift — the CoG reference moves over the stance sole's centre (SHIFT_S, smooth);
2. unload — the leaving sole's normal-force bound ramps to zero (UNLOAD_S), so its force goes
   continuously to zero before its contact is removed (the paper's force regularizer to zero);
3. lift — the contact is removed and the sole's pose target rises LIFT_HEIGHT (LIFT_S), then holds.
Back to double support the same in reverse: lower the sole to where it lifted off, restore its
contact with the bound ramping up, and shift the CoG back to the middle. A request waits for the
running transition to end.

In single support the lifted leg can swing (`swing(hz)`, Herzog §5.4 and Fig. 11): its hip and
knee flexion joints follow q_lift + a (1 − cos 2π f t) / 2 (SWING_AMPLITUDE, bending both further
than the lifted posture, so the sole only rises), the leg in joint space (`swing_leg` task) in
place of its sole pose. A swing stops at the end of a period, back in the lifted posture, and
before any stance change.

On a native tick the update runs in C++ (cpp/behaviours/stance.cpp; `native.py`).
"""

from dataclasses import fields

import numpy as np

from lab.controller.behaviours.balance import Balance
from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.references import SoleReferences
from lab.controller.tasks.posture import leg_joints
from lab.protocol import SWING_HZ_MAX

try:
    from lab._kernel import Stance as NativeStance
except ImportError:  # the native kernel is not built: every tick runs in Python
    NativeStance = None

STANCES = ("double", "left", "right")
SHIFT_S = 1.0  # s, CoG over the stance sole (or back to the middle)
UNLOAD_S = 0.5  # s, the leaving sole's normal-force bound from the full weight to zero
LIFT_S = 1.0  # s, the sole up by LIFT_HEIGHT (or down to the ground)
LIFT_HEIGHT = 0.10  # m, Herzog §5.4
NORMAL_MAX = 5000.0  # N, the bound of a sole that carries load freely (ContactLimits' default)
SWING_AMPLITUDE = (0.4, 0.6)  # rad, the hip and knee flexion's excursion from the lifted posture


def smooth(s: float) -> float:
    """0 → 1 with zero slope at both ends (a cosine ramp) for s in [0, 1], clamped outside."""
    s = min(max(s, 0.0), 1.0)
    return float(0.5 - 0.5 * np.cos(np.pi * s))


class Stance(Balance):
    """Stand on both soles or on one (`request`); the references carry sole pose targets for
    the `swing_sole` task."""

    name = "stance"
    lifts_feet = False  # the stance preset brings `swing_sole`, not the walking one
    references: SoleReferences  # Balance's, with a pose target per sole

    def __init__(self, robot: RobotModel, q_standing: np.ndarray) -> None:
        """Start in double support from the robot's current state (the model is up to date)."""
        super().__init__(robot, q_standing)
        base = self.references
        self.references = refs = SoleReferences(
            **{f.name: getattr(base, f.name) for f in fields(base)},
            sole_position=robot.contact_positions.copy(),
            sole_rotation=robot.contact_rotations.copy(),
            leg_swinging=np.zeros(len(robot.contacts), dtype=bool),
            leg_position=robot.joint_positions.copy(),
            leg_velocity=np.zeros(robot.na),
            leg_acceleration=np.zeros(robot.na),
        )
        refs.normal_force_max = np.full(len(robot.contacts), NORMAL_MAX)
        self._flexion = [flexion_joints(robot, i) for i in range(len(robot.contacts))]
        self._bend = np.sign(q_standing[7:])  # the side each joint bends to in the crouch
        self.swing_hz = 0.0  # asked for; 0: hold the lifted sole
        self._swing: tuple[float, float] | None = None  # (start time, frequency) of a swing
        self._lifted = robot.joint_positions.copy()  # the posture a swing starts and ends in
        self._periods_done = 0
        self.names = [contact.name for contact in robot.contacts]
        self.weight = robot.mass * float(np.linalg.norm(robot.gravity))
        self.middle = self.references.com.copy()
        self.stance = "double"  # where the robot is, or is going to
        self._from = "double"
        self._started: float | None = None  # time the running transition started
        self._pending: str | None = None
        self._ground = self.references.sole_position.copy()  # each sole where it stood
        self._native = NativeStance() if NativeStance is not None else None

    def request(self, stance: str) -> None:
        """Go to `stance` (double | left | right); raises ValueError naming the stances. A
        request while a transition runs waits for its end (a newer one replaces it)."""
        if stance not in STANCES:
            raise ValueError(f"unknown stance {stance!r} (stances: {', '.join(STANCES)})")
        if stance != "double" and stance not in self.names:
            raise ValueError(f"stance {stance!r}: this robot's soles are {self.names}")
        self._pending = stance
        self._native_stale = True

    def swing(self, hz: float) -> None:
        """Swing the lifted leg's hip and knee at `hz` (0 stops at the end of the period, in
        (0, SWING_HZ_MAX] starts in single support); raises ValueError for another frequency."""
        if not 0.0 <= hz <= SWING_HZ_MAX:
            raise ValueError(f"swing: frequency must be in [0, {SWING_HZ_MAX}] Hz, got {hz}")
        self.swing_hz = hz
        self._native_stale = True

    @property
    def busy(self) -> bool:
        """Whether a transition or a swing is running."""
        return self._started is not None or self._swing is not None

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Advance the running transition or swing, or start the pending one."""
        if self._native_tick(t, robot, command, touching):
            return
        if self._swing is not None or (
            self.swing_hz > 0.0 and self._started is None and self._pending is None
        ):
            self._update_swing(t, robot)
            return
        if self._started is None and self._pending is not None:
            pending, self._pending = self._pending, None
            if pending != self.stance:
                # Single to the other single goes through double support.
                self._from, self.stance = self.stance, pending
                if "double" not in (self._from, pending):
                    self.stance, self._pending = "double", pending
                self._started = t
        if self._started is None:
            return
        elapsed = t - self._started
        done = (
            self._to_single(elapsed)
            if self._from == "double"
            else self._to_double(elapsed, self.names.index(self._from))
        )
        if done:
            self._started = None

    def _to_single(self, elapsed: float) -> bool:
        refs = self.references
        stance = self.names.index(self.stance)
        leaving = 1 - stance
        target = self.middle.copy()
        target[:2] = self._ground[stance][:2]
        refs.com[:] = self.middle + smooth(elapsed / SHIFT_S) * (target - self.middle)
        unload = (elapsed - SHIFT_S) / UNLOAD_S
        refs.normal_force_max[leaving] = (
            NORMAL_MAX if unload <= 0.0 else (max(1.0 - unload, 0.0) * self.weight)
        )
        lift = (elapsed - SHIFT_S - UNLOAD_S) / LIFT_S
        if lift <= 0.0:
            return False
        refs.contact_active[leaving] = False
        refs.sole_position[leaving] = self._ground[leaving]
        refs.sole_position[leaving, 2] += LIFT_HEIGHT * smooth(lift)
        return lift >= 1.0

    def _to_double(self, elapsed: float, stance: int) -> bool:
        refs = self.references
        landing = 1 - stance
        lower = elapsed / LIFT_S
        refs.sole_position[landing] = self._ground[landing]
        refs.sole_position[landing, 2] += LIFT_HEIGHT * (1.0 - smooth(lower))
        if lower < 1.0:
            return False
        refs.contact_active[landing] = True
        load = (elapsed - LIFT_S) / UNLOAD_S
        refs.normal_force_max[landing] = min(load, 1.0) * self.weight if load < 1.0 else NORMAL_MAX
        shift = (elapsed - LIFT_S - UNLOAD_S) / SHIFT_S
        over = self.middle.copy()
        over[:2] = self._ground[stance][:2]
        refs.com[:] = over + smooth(shift) * (self.middle - over)
        return shift >= 1.0

    def _update_swing(self, t: float, robot: RobotModel) -> None:
        """Start, advance or end the leg swing (module docstring)."""
        refs = self.references
        if self.stance == "double":
            return
        leg = 1 - self.names.index(self.stance)
        if self._swing is None:
            self._swing = (t, self.swing_hz)
            self._lifted = robot.joint_positions.copy()
            self._periods_done = 0
            refs.leg_position[:] = self._lifted
            refs.leg_swinging[leg] = True
        start, hz = self._swing
        periods_done = int((t - start) * hz)
        stop = self.swing_hz != hz or self._pending is not None
        if stop and periods_done > self._periods_done:  # back in the lifted posture
            self._swing = None
            refs.leg_swinging[leg] = False
            refs.leg_position[:] = self._lifted
            refs.leg_velocity[:] = refs.leg_acceleration[:] = 0.0
            return
        self._periods_done = periods_done
        w = 2.0 * np.pi * hz
        phase = w * (t - start)
        for joint, amplitude in zip(self._flexion[leg], SWING_AMPLITUDE, strict=True):
            a = 0.5 * amplitude * self._bend[joint]
            refs.leg_position[joint] = self._lifted[joint] + a * (1.0 - np.cos(phase))
            refs.leg_velocity[joint] = a * w * np.sin(phase)
            refs.leg_acceleration[joint] = a * w * w * np.cos(phase)


def flexion_joints(robot: RobotModel, contact: int) -> np.ndarray:
    """The hip and knee flexion joints of a flat foot's leg (actuated indices): the first two of
    its leg's joints whose axis, seen from the sole, is the sole's lateral (y) axis."""
    rows = robot.force_slices[contact]
    angular = robot.Jc[rows.start + 3 : rows.start + 6, BASE_DOF:]  # sole frame (LOCAL)
    leg = leg_joints(robot)[contact]
    lateral = [j for j in leg if abs(angular[1, j]) > 0.9 * np.linalg.norm(angular[:, j])]
    return np.array(lateral[:2])
