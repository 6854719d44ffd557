"""Stepping on two point feet: the state machine of Kim 2016 Fig. 8a with the footstep planner
of §V (`pipm.py`).

One step, the swing foot s and the stance foot the other:

    dual support → lift transition (s unloaded, w 1 → 0, eqs. 9–10) → lift → land →
    land transition (s loaded, w 0 → 1) → dual support, the feet swapping roles.

In lift and land the swing foot tracks the swing ellipse of `swing.py` (`swing_feet` task)
from where it left the ground to the planned footstep; landing ends when the foot is felt on
the ground, or keeps descending until it is. The footstep comes from the velocity-reversal
planner, x and y separately: a first plan at lift-off, replanned every tick from 80 % of the
lift until landing begins (Kim §V: "the planner runs when the lifting phase reaches 80 %").
The CoM height above the stance foot is the PIPM's (level) height surface; the switching state
is predicted at the end of the landing. The velocity command [vx, vy] biases the reversal:
the planner aims at the commanded velocity t′ after the switch instead of zero (heading
frame), so the robot walks where it is steered. The step stays within `reach` of the stance
foot and the swing foot on its own side, at least `min_width` from the stance foot across.

Across (§V-2), y is planned before x and may retime the swing, which x then plans with:
Kim's rules (the switch comes where the PIPM's |ẏ| reaches `max_lateral_speed`; a switch whose
|ẏ| would be below `min_lateral_speed` waits until it is, up to `max_swing`), and, where
the reversal would need the swing foot closer than `min_width` to the stance foot or across it
(a crossover the legs cannot make without touching), the swing cut to `min_swing`: the foot
lands at the width limit at once, so that the other foot, on the side the CoM is heading, steps
sooner. A retimed swing keeps its path and moves along it faster or slower from where it is.

The trunk: base height above the stance foot (Kim controls the CoM height), level, at a heading
turned by the command's yaw rate (never more than YAW_LEAD_MAX ahead of the measured one); the
CoM's horizontal motion is left to the pendulum and the footsteps, as in Kim's single-support
task set [COM_z, q_Ry, q_Rx, foot].

On a tick whose model update the native kernel ran, `update` runs the same steps in C++ in one
call (cpp/behaviours/biped_step.cpp with pipm.cpp and swing.cpp, when built): it reads this
object's state when it changed since its last call and writes it back, so this object stays
current and this module stays the reference. The planner's prediction for the drawing is built
from the last plan's inputs when it is read.
"""

import math
from dataclasses import dataclass, fields
from enum import Enum

import numpy as np
import pinocchio as pin

from lab.controller.behaviours.balance import references_at_rest, standing_model
from lab.controller.behaviours.base import NoOptions
from lab.controller.behaviours.native import NativeTwin
from lab.controller.behaviours.pipm import (
    LinearSurface,
    PipmState,
    lateral_switch_time,
    plan_step,
    predicted_path,
)
from lab.controller.behaviours.swing import swing_reference
from lab.controller.behaviours.walking import YAW_ACCELERATION_LIMIT, rate_limited
from lab.controller.model import RobotModel
from lab.controller.references import References, WalkReferences

try:
    from lab._kernel import BipedStepping as NativeBipedStepping
except ImportError:  # the native kernel is not built: every tick runs the code below
    NativeBipedStepping = None

YAW_LEAD_MAX = 0.2  # rad, the heading reference never leads the measured yaw by more
PLAN_TOLERANCE = 1e-4  # m, the bisection's: a tenth of a millimetre on the footstep
# m/s², the commanded velocity's rate limit. A step from 0 to 0.3 m/s (or walking's 1 m/s²)
# needs footsteps beyond the reach within two steps: clipped there, the CoM outruns the feet
# and Bolt falls in 1.5–2 s (whether it turns or not); at 0.3 m/s² it walks 0.3 m/s and turns.
ACCELERATION_LIMIT = 0.3
RATE_LIMITS = (ACCELERATION_LIMIT, ACCELERATION_LIMIT, YAW_ACCELERATION_LIMIT)
# The last plan's inputs (BipedStepping.plan): when (s), the CoM and its velocity (heading frame,
# from the stance foot), the time to the switch (s), the step (heading frame, from the stance
# foot), the PIPM's height (m) and the stance foot (heading frame).
PLAN_FIELDS = (
    "t",
    "com_x",
    "com_y",
    "vx",
    "vy",
    "switch_in",
    "step_x",
    "step_y",
    "height",
    "origin_x",
    "origin_y",
)


def _wrap(angle: float) -> float:
    """The angle in [-π, π]."""
    return math.atan2(math.sin(angle), math.cos(angle))


class Phase(Enum):
    """The states of Fig. 8a."""

    DUAL = "dual"
    LIFT_TRANSITION = "lift_transition"
    LIFT = "lift"
    LAND = "land"
    LAND_TRANSITION = "land_transition"


@dataclass(frozen=True)
class SteppingTimes:
    """Durations (s) of the phases, Hume's (Kim: dual support 0.02 s in stepping, 0.079 s in
    walking) scaled to Bolt by its pendulum time constant; the step height (m), the planner's
    t′ (s), its impact velocity change (m/s), and where a footstep may go (m)."""

    dual: float = 0.02
    transition: float = 0.02
    lift: float = 0.12
    land: float = 0.08
    step_height: float = 0.04
    # t′ longer than the time from the reversal to the next switch makes the step-to-step map
    # contract: on a level PIPM the velocity at the next switch is −sinh(ω(T − t′))/sinh(ω t′)
    # times this one's (T the switch-to-switch time, 0.22–0.26 s here); Hume's 0.24 s scaled
    # by √(z/g) (0.13 s) would be T/2, neutral, and the lateral sway would wander.
    reversal_time: float = 0.16
    impact_velocity_change: float = 0.0
    replan_from: float = 0.8  # of the lift phase
    reach: float = 0.12
    lateral_offset: float = 0.02  # outwards, added to the planned y: the sway's amplitude
    # Across, from the stance foot: at 4 cm Bolt's legs (hip-knee-foot centre lines, solved by
    # IK at the landing) stay 4.0 cm apart; a crossover of 3 cm would need the foot 6 cm ahead
    # or behind for 3 cm, and its swing passes through the stance leg (docs/controller.md).
    min_width: float = 0.04
    max_width: float = 0.24
    min_swing: float = 0.16  # s, the shortest a swing may be cut to (at 0.12 the stance foot slid)
    # Kim's |ẏ| limit 0.65 m/s (Hume) scaled by √(z g) to Bolt's 0.3 m: the lateral phase plane
    # shortens the step so that the switch comes before the CoM is this fast sideways.
    max_lateral_speed: float = 0.36
    # Kim's lower limit, 0.1 m/s on Hume, scaled the same way: a switch slower sideways than
    # this is postponed until the CoM is this fast, so that the next lateral step has a sway
    # to reverse (§V-2), never beyond Hume's lift + land (0.49 s, Table IV) scaled to Bolt.
    min_lateral_speed: float = 0.055
    max_swing: float = 0.27


@dataclass(frozen=True)
class StepPrediction:
    """The planner's last answer for the step under way, in the heading frame (world origin,
    m): when it was made (s), the footstep, and the CoM's predicted (t, x, ẋ) along forward and
    lateral axes, over the stance foot to the switch and over the new foot for t′ after it
    (Kim Figs. 4–5)."""

    t: float
    foot: np.ndarray
    forward: np.ndarray  # (n, 3): t (s), x (m), ẋ (m/s)
    lateral: np.ndarray


class BipedStepping(NativeTwin, NoOptions):
    """Step on two point feet, feet placed by the velocity-reversal planner."""

    name = "biped_step"
    lifts_feet = True
    stack_preset = "kim_stepping"  # the stack it brings onto one that cannot swing feet

    def __init__(self, robot: RobotModel, q_standing: np.ndarray) -> None:
        if len(robot.contacts) != 2 or any(c.kind != "point" for c in robot.contacts):
            raise ValueError("biped_step needs a robot with exactly two point feet")
        here = q_standing.copy()
        here[:2] = robot.base_position[:2]
        yaw = pin.rpy.matrixToRpy(robot.base_rotation)[2]
        here[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, 0.0, yaw)).coeffs()
        at_rest = standing_model(robot, here)
        standing = references_at_rest(at_rest)
        refs = WalkReferences(**{f.name: getattr(standing, f.name) for f in fields(References)})
        feet = robot.contact_positions.copy()
        self.height = float(at_rest.base_position[2] - at_rest.contact_positions[:, 2].mean())
        self.com_height = float(at_rest.com[2] - at_rest.contact_positions[:, 2].mean())
        self.yaw = float(yaw)  # the heading reference, turned by the command's yaw rate
        self.t: float | None = None
        self.command = (0.0, 0.0, 0.0)  # [vx, vy, yaw_rate], rate-limited (RATE_LIMITS)
        refs.foot_position = feet.copy()
        refs.foot_velocity = np.zeros((2, 3))
        refs.foot_acceleration = np.zeros((2, 3))
        refs.force_weight = np.full(2, np.nan)
        refs.swing_tracked = np.zeros(2, dtype=bool)
        self.references = refs
        self.times = SteppingTimes()
        # The left foot (+y in the base frame) swings first.
        left = int(np.argmax((at_rest.contact_positions - at_rest.base_position)[:, 1]))
        self.sides = np.array([1.0, -1.0]) if left == 0 else np.array([-1.0, 1.0])
        self.swing = left
        self.phase = Phase.DUAL
        self.since: float | None = None
        self.liftoff = feet[left].copy()
        self.target = feet[left, :2].copy()
        # The swing clock: the fraction of the swing done, u = u0 + (t − t0) / duration, so that
        # a swing cut short keeps its place on the path (`_shorten`).
        self.swing_start = self.swing_t0 = self.swing_u0 = 0.0
        self.swing_duration = self.times.lift + self.times.land
        self.shortened = 0  # swings cut short by the lateral planner
        self.lengthened = 0  # swings lengthened by it
        self.steps = 0  # touchdowns
        self.plans = 0
        self.plan = np.zeros(len(PLAN_FIELDS))  # the last plan's inputs (PLAN_FIELDS)
        self._prediction: tuple[int, float, StepPrediction] | None = None  # plans, t, answer
        self._native = NativeBipedStepping() if NativeBipedStepping is not None else None
        self._native_stale = True  # the native tick must read this object's state first

    @property
    def stepping(self) -> "BipedStepping":
        """It steps: its counts and the planner's prediction (behaviours/base.py, Stepping)."""
        return self

    @property
    def prediction(self) -> StepPrediction | None:
        """The planner's last answer (Kim Figs. 4–5) for the drawing, built from `plan` when
        read; None before the first plan."""
        if self.plans == 0:
            return None
        if self._prediction is None or self._prediction[:2] != (self.plans, self.plan[0]):
            t, *com, vx, vy, switch_in, step_x, step_y, height, ox, oy = self.plan.tolist()
            surface, origin, step = LinearSurface(height), (ox, oy), (step_x, step_y)
            paths = (
                predicted_path(
                    PipmState(t, com[axis], (vx, vy)[axis]),
                    switch_in,
                    step[axis],
                    self.times.reversal_time,
                    surface,
                    origin=origin[axis],
                )
                for axis in range(2)
            )
            foot = np.array([ox + step_x, oy + step_y])
            self._prediction = (self.plans, t, StepPrediction(t, foot, *paths))
        return self._prediction[2]

    # ------------------------------------------------------------------------ the tick
    def native_twin(self) -> "NativeBipedStepping | None":
        """The native tick, once the first (Python) tick has started the clock."""
        return self._native if self.since is not None else None

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Advance the state machine to time `t` (s) and set the references (module docstring)."""
        if self.since is None:
            self.since = self.t = t
        if self._native_tick(t, robot, command, touching):  # the steps below, in C++
            return
        steps = [(t - self.t) * limit for limit in RATE_LIMITS]
        self.command = rate_limited(self.command, command.tolist(), steps)
        command = np.array(self.command)
        yaw = float(pin.rpy.matrixToRpy(robot.base_rotation)[2])
        lead = _wrap(self.yaw + float(command[2]) * (t - self.t) - yaw)
        self.yaw, self.t = yaw + min(max(lead, -YAW_LEAD_MAX), YAW_LEAD_MAX), t
        times, refs, s = self.times, self.references, self.swing
        elapsed = t - self.since
        if self.phase is Phase.DUAL and elapsed >= times.dual:
            self._enter(Phase.LIFT_TRANSITION, t)
        elif self.phase is Phase.LIFT_TRANSITION and elapsed >= times.transition:
            self.liftoff = robot.contact_positions[s].copy()
            self.swing_start = self.swing_t0 = t
            self.swing_u0, self.swing_duration = 0.0, times.lift + times.land
            self._enter(Phase.LIFT, t)
            self.target = self._plan(robot, command, t)
        elif self.phase is Phase.LIFT and self._swing_done(t) >= self._lift_fraction:
            self._enter(Phase.LAND, t)
        elif (
            self.phase is Phase.LAND
            and touching[s]
            and self._swing_done(t) >= (times.lift + 0.5 * times.land) / (times.lift + times.land)
        ):
            self.steps += 1
            self._enter(Phase.LAND_TRANSITION, t)
        elif self.phase is Phase.LAND_TRANSITION and elapsed >= times.transition:
            self.swing = 1 - s
            self._enter(Phase.DUAL, t)
        elapsed = t - self.since
        s = self.swing
        stance = 1 - s

        in_air = self.phase in (Phase.LIFT, Phase.LAND)
        refs.contact_active[:] = True
        refs.contact_active[s] = not in_air
        refs.force_weight[:] = np.nan
        if self.phase is Phase.LIFT_TRANSITION:
            refs.force_weight[s] = max(0.0, 1.0 - elapsed / times.transition)  # eq. 9–10
        elif self.phase is Phase.LAND_TRANSITION:
            refs.force_weight[s] = min(1.0, elapsed / times.transition)
        refs.swing_tracked[:] = False
        refs.swing_tracked[s] = self.phase is not Phase.DUAL
        if self.phase in (Phase.LIFT_TRANSITION, Phase.LAND_TRANSITION):
            refs.foot_velocity[s] = refs.foot_acceleration[s] = 0.0  # held where it stands
        if self.phase in (Phase.LIFT_TRANSITION, Phase.LAND_TRANSITION) and elapsed == 0.0:
            refs.foot_position[s] = robot.contact_positions[s]
        if elapsed == 0.0:  # the posture (lowest priority) holds the joints where they are
            refs.posture[:] = robot.joint_positions
        if in_air:
            done = self._swing_done(t)
            if self.phase is Phase.LIFT and done >= times.replan_from * self._lift_fraction:
                self.target = self._plan(robot, command, t)
                done = self._swing_done(t)
            refs.foot_position[:], refs.foot_velocity[:] = robot.contact_positions, 0.0
            refs.foot_acceleration[:] = 0.0
            duration = self.swing_duration
            swing = swing_reference(
                self.liftoff, self.target, times.step_height, done * duration, duration
            )
            refs.foot_position[s], refs.foot_velocity[s], refs.foot_acceleration[s] = swing
        on_ground = robot.contact_positions[stance, 2] if in_air else robot.contact_positions[:, 2]
        refs.base_height = float(np.mean(on_ground)) + self.height
        refs.base_rotation = pin.rpy.rpyToMatrix(0.0, 0.0, self.yaw)
        refs.base_angular_velocity[:] = 0.0, 0.0, float(command[2])
        refs.com[:] = robot.com  # the CoM moves as the pendulum: only reported, not tracked
        refs.com[2] = float(np.mean(on_ground)) + self.com_height

    def _enter(self, phase: Phase, t: float) -> None:
        self.phase, self.since = phase, t

    @property
    def _lift_fraction(self) -> float:
        return self.times.lift / (self.times.lift + self.times.land)

    def _swing_done(self, t: float) -> float:
        """The fraction of the swing done at time `t` (s); above 1 while reaching down."""
        return self.swing_u0 + (t - self.swing_t0) / self.swing_duration

    def _retime(self, t: float, switch_in: float) -> None:
        """End the swing `switch_in` s after `t` instead: the rest of the path, walked faster or
        slower. A swing's first retiming is counted, as cut or lengthened."""
        done = self._swing_done(t)
        if self.swing_u0 == 0.0:
            longer = switch_in > (1.0 - done) * self.swing_duration
            self.lengthened += longer
            self.shortened += not longer
        self.swing_u0, self.swing_t0 = done, t
        self.swing_duration = switch_in / (1.0 - done)

    def _plan(self, robot: RobotModel, command: np.ndarray, t: float) -> np.ndarray:
        """The footstep (world x, y) for the swing foot from the CoM state at time `t` (s) and
        the stance foot; y first, which may shorten the swing (module docstring)."""
        times, s = self.times, self.swing
        switch_in = (1.0 - self._swing_done(t)) * self.swing_duration
        shortest = min(switch_in, max(0.0, times.min_swing - (t - self.swing_start)))
        longest = max(switch_in, times.max_swing - (t - self.swing_start))
        stance = robot.contact_positions[1 - s]
        yaw = float(pin.rpy.matrixToRpy(robot.base_rotation)[2])
        c, sn = math.cos(yaw), math.sin(yaw)
        heading = np.array([[c, -sn], [sn, c]])  # heading frame (the body's yaw) → world
        com = heading.T @ (robot.com[:2] - stance[:2])
        velocity = heading.T @ robot.com_velocity[:2]
        target_velocity = np.asarray(command[:2], dtype=float)
        surface = LinearSurface(height=max(float(robot.com[2] - stance[2]), 0.05))
        side = self.sides[s]

        def foot(axis: int, switch_in: float) -> float:
            now = PipmState(0.0, float(com[axis]), float(velocity[axis]))
            return plan_step(
                now,
                0.0,
                switch_in,
                times.reversal_time,
                surface,
                times.impact_velocity_change if axis == 0 else 0.0,
                reach=times.reach + abs(float(com[axis])),
                velocity=float(target_velocity[axis]),
                tolerance=PLAN_TOLERANCE,
            ).foot

        lateral = PipmState(0.0, float(com[1]), float(velocity[1]))
        capped = lateral_switch_time(
            lateral,
            0.0,
            switch_in,
            surface,
            times.max_lateral_speed,
            times.min_lateral_speed,
            shortest,
            longest,
        )
        y = foot(1, capped) + side * times.lateral_offset
        if side * y < times.min_width and capped > shortest:  # a crossover: step at once
            capped = shortest
            y = foot(1, capped) + side * times.lateral_offset
        if abs(capped - switch_in) > 1e-9:
            self._retime(t, capped)
        step = np.array([foot(0, capped), y])
        step[0] = float(np.clip(step[0], -times.reach, times.reach))
        step[1] = side * float(np.clip(side * step[1], times.min_width, times.max_width))
        self.plans += 1
        origin = heading.T @ stance[:2]  # the stance foot, heading frame
        self.plan[:] = (t, *com, *velocity, capped, *step, surface.height, *origin)
        return stance[:2] + heading @ step


BIPED_BEHAVIOURS = {BipedStepping.name: BipedStepping}
