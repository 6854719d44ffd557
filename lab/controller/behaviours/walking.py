"""Walking: the walking pattern generator of Raiola §3 as a behaviour (trot, crawl).

Every tick it turns the velocity command [vx, vy, yaw_rate] (heading frame) and the measured
foot contacts into references: the gait scheduler decides which legs stand and which swing
(`gait.py`), the foothold planner where each swinging foot lands (`footholds.py`), the swing
ellipse how it gets there (`swing.py`). Stance legs carry a normal-force bound that ramps at
both ends of the stance; swinging feet get position, velocity and acceleration references for the
`swing_feet` task (`WalkReferences`). The trunk keeps level with the commanded heading (yaw
integrated from the command, never further than YAW_LEAD_MAX from the measured yaw), its height
above the mean of the stance feet (Raiola eq. 17: blind, the height follows the ground), and the
commanded velocity for the tasks that track one (Hutter Table 7); the CoM reference moves with
the base for stacks that have a CoM task. The posture reference (joint positions and velocities)
follows the feet: the swing trajectories and, in stance, the commanded base twist and the base
height (Raiola eqs. 30–32, `leg_posture.py`).

Gait, step height, cycle time and foothold planner can change while walking: a new Walking
continues from the previous one (`continue_from`), legs in the air finish their step.

On a tick whose model update the native kernel ran, `update` runs the same steps in C++ in one
call (cpp/behaviours/walking.cpp, with gait.cpp, footholds.cpp, swing.cpp and leg_posture.cpp,
when built): it reads this object's state when it changed since its last call, and writes the
state back, so this object stays current and this module stays the reference.
"""

import math
from collections.abc import Callable
from dataclasses import fields

import numpy as np
import pinocchio as pin

from lab.controller.behaviours.balance import references_at_rest, standing_model
from lab.controller.behaviours.base import Behaviour, BehaviourDefaults
from lab.controller.behaviours.footholds import FOOTHOLD_PLANNERS, GRAVITY, FootholdQuery
from lab.controller.behaviours.gait import GAITS, GaitPattern, GaitScheduler, LegState
from lab.controller.behaviours.leg_posture import LegPostureReference
from lab.controller.behaviours.native import NativeTwin
from lab.controller.behaviours.swing import swing_reference
from lab.controller.model import RobotModel
from lab.controller.references import References, WalkReferences

try:
    from lab._kernel import Walking as NativeWalking
except ImportError:  # the native kernel is not built: every tick runs the code below
    NativeWalking = None

STEP_HEIGHT_FRACTION = 0.15  # default step height, of the base height above the feet
ACCELERATION_LIMIT = 1.0  # m/s², commanded linear velocity is rate-limited to this
YAW_ACCELERATION_LIMIT = 2.0  # rad/s², commanded yaw rate likewise
RATE_LIMITS = (ACCELERATION_LIMIT, ACCELERATION_LIMIT, YAW_ACCELERATION_LIMIT)
YAW_LEAD_MAX = 0.2  # rad, the yaw reference never leads the measured yaw by more
HIP_VELOCITY_TIME_CONSTANT = 0.1  # s, low-pass on the measured hip velocity (Raibert feedback)
UNBOUNDED_LOADS = 5.0  # a fully loaded stance leg may carry this many body weights
CYCLE_TIME_RANGE = (0.2, 5.0)  # s


def _roles(hips: list[list[float]]) -> tuple[str, ...]:
    """LF/RF/LH/RH of each foot from where it stands relative to the base (x fore, y left)."""
    roles = tuple(("L" if y > 0 else "R") + ("F" if x > 0 else "H") for x, y in hips)
    if sorted(roles) != sorted(("LF", "RF", "LH", "RH")):
        raise ValueError(f"walking needs one foot per quadrant, got {roles}")
    return roles


def rate_limited(
    current: tuple[float, ...], target: list[float], steps: list[float]
) -> tuple[float, ...]:
    """Each value moved towards its target by at most its step."""
    moves = zip(current, target, steps, strict=True)
    return tuple(x + min(max(x_t - x, -step), step) for x, x_t, step in moves)


def _wrap(angle: float) -> float:
    """The angle in [-π, π]."""
    return math.atan2(math.sin(angle), math.cos(angle))


class Walking(NativeTwin, BehaviourDefaults):
    """Walk with `gait` on four point feet, steered by the velocity command."""

    lifts_feet = True

    def __init__(self, robot: RobotModel, q_standing: np.ndarray, gait: GaitPattern) -> None:
        at_rest = standing_model(robot, q_standing)
        standing = references_at_rest(at_rest)
        self.references = WalkReferences(
            **{f.name: getattr(standing, f.name) for f in fields(References)}
        )
        n = len(robot.contacts)
        base = q_standing[:3]
        feet = at_rest.contact_positions.copy()
        self.hips = (feet - base)[:, :2].tolist()  # x, y of each foot under its hip
        self.roles = _roles(self.hips)
        self.height = float(base[2] - feet[:, 2].mean())
        self.com_offset = at_rest.com - base
        self.full_load = robot.mass * GRAVITY
        self.gait = gait
        self.name = gait.name
        self.cycle_time = gait.cycle_periods * np.sqrt(self.height / GRAVITY)
        self.step_height = STEP_HEIGHT_FRACTION * self.height
        self.footholds = "robocentric"
        self._configured: set[str] = set()
        self.scheduler: GaitScheduler | None = None
        self.t = 0.0
        self.command = (0.0, 0.0, 0.0)  # [vx, vy, yaw_rate], rate-limited
        self.yaw_ref = 0.0
        self.measured_twist = (0.0, 0.0, 0.0)  # low-passed base vx, vy (H axes), yaw rate
        self.liftoff = feet
        refs = self.references
        refs.normal_force_max = np.full(n, UNBOUNDED_LOADS * self.full_load)
        # The feet's position, velocity and acceleration references in one array; refs.foot_*
        # are views of its three layers, so that a foot's swing reference is one assignment.
        self.foot_references = np.zeros((3, n, 3))
        self.foot_references[0] = feet
        refs.foot_position, refs.foot_velocity, refs.foot_acceleration = self.foot_references
        refs.posture_weight = np.ones(n)
        self.posture = LegPostureReference(at_rest, refs.posture)
        refs.posture, refs.posture_velocity = self.posture.position, self.posture.velocity
        point_feet = all(contact.kind == "point" for contact in robot.contacts)
        self._native = NativeWalking() if NativeWalking is not None and point_feet else None
        self._native_stale = True  # the native tick must read this object's state first

    # ------------------------------------------------------------------------ parameters
    def configure(
        self,
        step_height: float | None = None,
        cycle_time: float | None = None,
        footholds: str | None = None,
    ) -> None:
        """Set the step height (m), cycle time (s) or foothold planner; raises ValueError or
        KeyError naming the bad value and changes nothing then."""
        if step_height is not None and not 0.0 < step_height <= 0.5 * self.height:
            raise ValueError(
                f"step_height must be in (0, {0.5 * self.height:.3f}] m for this robot, "
                f"got {step_height}"
            )
        lo, hi = CYCLE_TIME_RANGE
        if cycle_time is not None and not lo <= cycle_time <= hi:
            raise ValueError(f"cycle_time must be in [{lo}, {hi}] s, got {cycle_time}")
        if footholds is not None and footholds not in FOOTHOLD_PLANNERS:
            raise KeyError(
                f"unknown foothold planner {footholds!r} (planners: {', '.join(FOOTHOLD_PLANNERS)})"
            )
        for name, value in (
            ("step_height", step_height),
            ("cycle_time", cycle_time),
            ("footholds", footholds),
        ):
            if value is not None:
                setattr(self, name, value)
                self._configured.add(name)
        self._native_stale = True
        if self.scheduler is not None:
            self.scheduler.set_gait(self.gait, self.cycle_time)

    def continue_from(self, previous: Behaviour) -> None:
        """Take over a walking behaviour in stride: its legs, clock and steering state, and the
        step height and planner unless this one was configured with its own."""
        if not isinstance(previous, Walking) or previous.scheduler is None:
            return
        self.scheduler = GaitScheduler(self.roles, self.gait, self.cycle_time, previous.t)
        self.scheduler.take_state(previous.scheduler)
        self.t, self.command, self.yaw_ref = previous.t, previous.command, previous.yaw_ref
        self.measured_twist = previous.measured_twist
        self.liftoff = previous.liftoff.copy()
        self.posture.position[:] = previous.posture.position
        for name in ("step_height", "footholds"):
            if name not in self._configured:
                setattr(self, name, getattr(previous, name))
        self._native_stale = True

    # ------------------------------------------------------------------------ the tick
    def native_twin(self) -> "NativeWalking | None":
        """The native tick, once the first (Python) tick has started the gait's clock."""
        return self._native if self.scheduler is not None else None

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """One tick of the walking pattern generator (module docstring): rate-limit the command
        (m/s, rad/s), advance the gait from the measured contacts, plan the swinging feet, and
        set the trunk, CoM and posture references (world axes)."""
        R = robot.base_rotation
        yaw = math.atan2(R[1, 0], R[0, 0])
        if self.scheduler is None:
            self.scheduler = GaitScheduler(self.roles, self.gait, self.cycle_time, t)
            self.t, self.yaw_ref = t, yaw
        if self._native_tick(t, robot, command, touching):  # the steps below, in C++
            return
        dt = t - self.t
        self.t = t
        steps = [dt * limit for limit in RATE_LIMITS]
        self.command = vx, vy, yaw_rate = rate_limited(self.command, command.tolist(), steps)
        lead = _wrap(self.yaw_ref + yaw_rate * dt - yaw)
        self.yaw_ref = yaw + min(max(lead, -YAW_LEAD_MAX), YAW_LEAD_MAX)
        c, s = math.cos(yaw), math.sin(yaw)

        scheduler = self.scheduler
        legs = scheduler.legs
        events = scheduler.advance(t, touching.tolist())
        if events:
            changed = {event.leg for event in events}
            standing = [
                i for i, leg in enumerate(legs) if leg.state is LegState.STANCE and i not in changed
            ]
            for event in events:
                if event.kind == "liftoff":
                    self.liftoff[event.leg] = robot.contact_positions[event.leg]
                landed = event.kind == "touchdown"
                self.posture.restart(robot, event.leg, standing if landed else [])
        self._filter_twist(robot, c, s, dt)

        refs = self.references
        stance = [leg.state is LegState.STANCE for leg in legs]
        refs.contact_active[:] = stance
        for i, standing in enumerate(stance):
            load = scheduler.load(i, t)  # 0 in the air
            refs.posture_weight[i] = load  # the leg's postural rows fade with its load
            if standing:
                refs.normal_force_max[i] = (
                    load * self.full_load if load < 1.0 else UNBOUNDED_LOADS * self.full_load
                )
        feet_z = robot.contact_positions[:, 2].tolist()
        on_ground = [z for z, standing in zip(feet_z, stance, strict=True) if standing]
        if on_ground:
            refs.base_height = sum(on_ground) / len(on_ground) + self.height
        if not all(stance):
            self._swing_feet(t, robot, yaw, stance)

        refs.base_rotation = pin.rpy.rpyToMatrix(0.0, 0.0, self.yaw_ref)
        refs.base_angular_velocity[:] = 0.0, 0.0, yaw_rate
        refs.base_linear_velocity[:] = c * vx - s * vy, s * vx + c * vy, 0.0
        x, y, z = robot.base_position.tolist()
        ox, oy, oz = self.com_offset.tolist()
        refs.com[:] = x + c * ox - s * oy, y + s * ox + c * oy, refs.base_height + oz
        refs.com_velocity[:] = refs.base_linear_velocity
        self.posture.update(
            robot,
            dt,
            refs.contact_active,
            refs.foot_position,
            refs.foot_velocity,
            refs.base_linear_velocity,
            refs.base_angular_velocity,
            refs.base_height - z,  # ΔH_z, eq. 32
        )

    def _swing_feet(self, t: float, robot: RobotModel, yaw: float, stance: list[bool]) -> None:
        """Foothold and swing references of the legs in the air."""
        planner = FOOTHOLD_PLANNERS[self.footholds]
        swing_time = self.scheduler.swing_time
        base_xy = robot.base_position[:2].tolist()
        vx, vy, yaw_rate = self.command
        base_vx, base_vy, spin = self.measured_twist
        for i, leg in enumerate(self.scheduler.legs):
            if stance[i]:
                continue
            elapsed = t - leg.since
            hip_x, hip_y = self.hips[i]
            query = FootholdQuery(
                base_xy=base_xy,
                yaw=yaw,
                hip=(hip_x, hip_y),
                velocity=(vx, vy),
                yaw_rate=yaw_rate,
                hip_velocity=(base_vx - spin * hip_y, base_vy + spin * hip_x),  # + ω_z ẑ × hip
                height=self.height,
                swing_left=max(leg.swing_duration - elapsed, 0.0),
                stance_time=self.cycle_time - swing_time,
                swing_time=swing_time,
            )
            self.foot_references[:, i] = swing_reference(
                self.liftoff[i], planner(query), self.step_height, elapsed, leg.swing_duration
            )

    def _filter_twist(self, robot: RobotModel, c: float, s: float, dt: float) -> None:
        """Low-pass the measured base velocity (H axes; c, s: cosine and sine of the base yaw)
        and yaw rate, for the Raibert feedback. A hip point's velocity is v_base + ω × r with
        r = [hip, 0], in the plane v_base,xy + ω_z ẑ × hip: ẑ × hip turns with the yaw, and the
        filter is linear, so filtering the base twist filters every hip's velocity."""
        alpha = dt / (HIP_VELOCITY_TIME_CONSTANT + dt)
        vx, vy, _ = robot.base_linear_velocity_world.tolist()
        spin = float(robot.base_angular_velocity_world[2])
        fx, fy, fs = self.measured_twist
        self.measured_twist = (
            fx + alpha * (c * vx + s * vy - fx),
            fy + alpha * (c * vy - s * vx - fy),
            fs + alpha * (spin - fs),
        )


def _factory(gait: GaitPattern) -> Callable[[RobotModel, np.ndarray], Walking]:
    def make(robot: RobotModel, q_standing: np.ndarray) -> Walking:
        return Walking(robot, q_standing, gait)

    return make


WALKING_BEHAVIOURS: dict[str, Callable[[RobotModel, np.ndarray], Walking]] = {
    name: _factory(gait) for name, gait in GAITS.items()
}
