"""Session: one robot in one MuJoCo world under the whole-body controller, one tick at a time.

The same object runs headless (tests, scenarios, benchmarks: as fast as the CPU allows) and
inside the realtime sim process (which adds the schedule and Zenoh around it). Commands arrive as
(verb, JSON payload), are validated into their lab.protocol struct by `parse_command`, and are
applied between ticks (`_apply`: one case per struct); a rejected command changes nothing and the
reply names the problem. What a session publishes (telemetry, the drawing state) is built in
`telemetry.py`.
"""

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import assert_never

import numpy as np
import pinocchio as pin

from lab import protocol as cmd
from lab.controller.behaviours import BEHAVIOURS, Balance, Behaviour
from lab.controller.behaviours.stance import Stance
from lab.controller.behaviours.walking import WALKING_BEHAVIOURS
from lab.controller.constraints import ContactLimits
from lab.controller.controller import ControllerConfig, ControlOutput, Ran
from lab.controller.hand_targets import HandTargets
from lab.controller.hierarchy import METHODS, HierarchySolution
from lab.controller.hierarchy.formulations import FORMULATIONS
from lab.controller.hierarchy.solution import SOLVED, SolveStatus
from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.momentum import MOMENTUM_MODES, GainFuture, LqrProblem
from lab.controller.native import KERNELS, NativeController
from lab.controller.qp import SOLVERS
from lab.controller.stack import Stack, StackError
from lab.description import ROBOT_NAMES, load_description, robot_names
from lab.protocol import TaskGains
from lab.realism.contact_estimate import estimated_contact_forces
from lab.realism.knobs import PRESET_NAMES as REALISM_PRESETS
from lab.realism.knobs import RealismKnobs, knobs_from, preset
from lab.realism.layer import NativeRealismLayer, RealismLayer, realism_layer
from lab.realism.model_error import perturbed_model
from lab.robot import FramePlacements, Robot, build_robot, with_raised_contact
from lab.scenes import SCENE_ROBOTS, SCENES, START_RISE
from lab.stack_presets import PRESET_NAMES, load_stack_preset
from lab.world.estimator import BaseEstimator
from lab.world.memory import release_free_memory
from lab.world.native_tick import NativeTick, TickStatus
from lab.world.plant import MujocoPlant, SimulationDiverged
from lab.world.telemetry import (
    hierarchy_report,
    internal_force_report,
    momentum_gain_report,
    momentum_report,
    state_message,
    task_gains_report,
    telemetry_in_two,
    telemetry_message,
)
from lab.world.warning_capture import WarningCapture

FALL_HEIGHT_FRACTION = 0.5  # fallen when the base is lower than this fraction of standing height
FALL_TILT = 1.0  # rad: fallen when the base tilts further than this from upright
FALL_CHECK_PERIOD = 10  # ticks between fall checks
# s: a body other than a foot touching the terrain this long is a fall. Shorter is a stumble: a
# blind trot over tiles grazes a shin on a tile edge for a stance phase (≤ 0.35 s) and walks on.
FALL_CONTACT_S = 0.5
TOUCH_FORCE = 1.0  # N: a foot pressing on the ground harder than this touches it
# With the contact force estimated from torques (realism's contact_estimate, Raiola eq. 18): a
# foot touches when its estimated normal force exceeds this fraction of its share of the weight.
# The estimate neglects the leg's acceleration: ANYmal's swinging legs read up to 0.65 of it
# (trotting at 0.3 m/s), stance legs 1.5-2.4; at 0.15 false touchdowns felled the trot.
ESTIMATED_TOUCH_FRACTION = 0.8
MAX_EVENTS = 256  # events kept for pop_events; older ones are dropped
FAILURE_EVENT_PERIOD = 0.5  # s of sim time between two solver_failure events
# s of sim time a warning of the controller (e.g. nullspace's ActiveSetCapWarning) stays in
# telemetry's `controller_warnings` after the last tick that raised it
WARNING_HOLD_S = 0.5
# The event each status other than ok raises (at most one per FAILURE_EVENT_PERIOD each).
STATUS_EVENTS = {
    "failed": "solver_failure",
    "fallback": "solver_fallback",
    "capped": "solver_capped",
    "violated": "solver_violation",
}
# A fallen robot's joints are damped, as drives in a fall protection's damping mode: b = τ_max /
# this speed, so the drive's full torque brakes a joint turning at it. Undamped, Solo12's 38 g
# shanks spun at up to 900 rad/s (1 ms steps) and MuJoCo's integration diverged
# (docs/architecture.md, "Faults").
LIMP_DAMPING_SPEED = 10.0  # rad/s
# s: a sim divergence this soon after the previous one pauses the session instead of resetting
# the robot again (a diverging set-up would otherwise reset it every few ticks).
DIVERGENCE_REPEAT_S = 1.0
# The stack a gait that lifts feet brings along when the current one has no swing_feet task
# (a robot's default stack is for standing): Raiola's S3, the stack of the trot scenarios.
WALKING_PRESET = "raiola_s3"
STANCE_PRESET = (
    "herzog_table4"  # the `stance` command's stack when the current one cannot lift a sole
)


@dataclass
class SessionConfig:
    """What a session is built from: robot, scene, and the controller's initial choices (None =
    the robot's default). Commands change the controller's own `ControllerConfig`, the one
    source of truth while the session runs; a rebuild reads it back (`Session._live_config`)."""

    robot: str = "anymal"
    scene: str = "flat"
    method: str = "cascade"  # hierarchy method: cascade | weighted | nullspace
    solver: str = "daqp"
    formulation: str = "qdd_force"  # `nullspace` only: its optimization vector (Hutter 2014 §4)
    stack: list[list[str]] | None = None
    gains: dict[str, dict[str, float]] = field(default_factory=dict)
    timestep: float = 1e-3
    kernel: str | None = None  # native | python; None: the robot's, else native when built
    terrain_seed: int | None = None  # of a scene with random terrain (rough); None: its own
    # sensors, delays, actuators, drive limits and model error (lab/realism); default ideal
    realism: RealismKnobs = field(default_factory=RealismKnobs)


@dataclass
class ControllerWarning:
    """A warning the controller raised: its last message, the sim time of the last tick that
    raised it (s) and how many ticks did since the last reset."""

    message: str
    t: float
    ticks: int


@dataclass
class Push:
    body: str
    force: np.ndarray
    point: np.ndarray | None
    ends_at: float


@dataclass
class SessionParts:
    """What a robot and scene make of a session: built by `build_parts` (on any thread: it
    touches no running session), swapped in by `Session.install`."""

    config: SessionConfig
    robot: Robot
    plant: MujocoPlant
    model: RobotModel
    controller: NativeController
    frame_placements: FramePlacements
    native_tick: NativeTick
    realism: RealismLayer | NativeRealismLayer
    estimator: BaseEstimator
    behaviour: Behaviour | None = None


def build_parts(config: SessionConfig) -> SessionParts:
    """Plant, model and controller for `config`; raises KeyError or ValueError on bad names."""
    if config.robot not in (known := robot_names()):
        raise KeyError(f"unknown robot {config.robot!r} (robots: {', '.join(known)})")
    if config.scene not in SCENES:
        raise KeyError(f"unknown scene {config.scene!r} (scenes: {', '.join(SCENES)})")
    made_for = SCENE_ROBOTS.get(config.scene, (config.robot,))
    if config.robot not in made_for:
        raise ValueError(
            f"scene {config.scene!r} is made for robot {', '.join(made_for)} only, "
            f"not {config.robot!r}"
        )
    description = load_description(config.robot)
    robot = build_robot(description)
    if config.scene in START_RISE:  # one foot starts on a block
        robot = with_raised_contact(robot, *START_RISE[config.scene])
    plant = MujocoPlant(robot, config.scene, config.timestep, config.terrain_seed)
    knobs = config.realism
    plant.set_drive_limits(knobs.torque_saturation, knobs.coulomb_friction, knobs.viscous_friction)
    # the controller's model: the simulator's, or a copy with model error (lab/realism)
    model = RobotModel(perturbed_model(robot.model, *knobs.model_error), robot.contacts)
    gains = dict(description.gains)
    for name, overrides in config.gains.items():
        gains[name] = replace(gains.get(name, TaskGains()), **overrides)
    controller = NativeController(
        model,
        Balance(model, robot.q_standing).references,
        ControllerConfig(
            stack=Stack.of(config.stack or description.stack),
            gains=gains,
            method=config.method,
            solver=config.solver,
            formulation=config.formulation,
            limits=ContactLimits(friction=description.friction),
            kernel=config.kernel or description.kernel or "native",
        ),
        robot.torque_limits,
    )
    controller.set_hands(tuple(frame for _, frame in description.hands))
    native_tick = NativeTick(plant, controller)
    layer = realism_layer(knobs, model.na, config.timestep)
    estimator = BaseEstimator(knobs, robot, config.timestep)
    return SessionParts(
        config,
        robot,
        plant,
        model,
        controller,
        FramePlacements(robot),
        native_tick,
        layer,
        estimator,
    )


class Session:
    """One robot in one MuJoCo world under the whole-body controller (module docstring).
    `gain_designer`, when given (`lab serve`: a worker process, gain_designer.py), designs the
    momentum task's LQR gains off the loop; headless sessions design them at once."""

    # The parts a robot and scene make (SessionParts), swapped in together by `_install`.
    config: SessionConfig
    robot: Robot
    plant: MujocoPlant
    model: RobotModel
    controller: NativeController
    frame_placements: FramePlacements
    estimator: BaseEstimator

    def __init__(
        self,
        config: SessionConfig | None = None,
        gain_designer: Callable[[LqrProblem], GainFuture] | None = None,
    ) -> None:
        self.config = config or SessionConfig()
        self._gain_designer = gain_designer
        self._events: list[dict] = []
        self.divergences = 0  # sim divergences since the session started
        # ticks computed by each (kernel, method, solver, formulation), since the session started
        self.ran_ticks: dict[Ran, int] = {}
        # ticks whose controller failed since the session started (telemetry's qp.failures):
        # a reset or a robot switch does not clear it, so it never reads fewer than the
        # solver_failure events seen (the soak's report once said 0 beside 35 of them)
        self.qp_failures = 0
        # False: every tick runs the Python path (the reference the native tick is held to)
        self.native_ticks = True
        self.tick_note = ""  # why the last tick ran the Python path ('' when it ran native)
        self.behaviour: Behaviour | None = None  # set by _build, replaced by the gait command
        self._install(build_parts(self.config))  # raises on bad names

    # ----------------------------------------------------------------------------- set-up
    def _install(self, parts: SessionParts) -> SessionParts:
        """Replace the running session's parts by `parts` (the robot standing, nothing
        commanded); the old parts, for the caller to drop where it likes (a thread beside the
        loop frees them there, lab/runtime/switch.py)."""
        old = SessionParts(
            *(getattr(self, name, None) for name in SessionParts.__dataclass_fields__)
        )
        for name in SessionParts.__dataclass_fields__:
            setattr(self, name, getattr(parts, name))
        self.controller.set_momentum_designer(self._gain_designer)
        self._output = None
        self._gait_stack: list[list[str]] | None = None  # the levels a gait brought along
        self._reset_state()
        return old

    def switch_config(self, command: cmd.RobotCommand | cmd.SceneCommand) -> SessionConfig:
        """The configuration a `robot` or `scene` command asks for: the live one (the
        controller's choices kept; a new robot starts with its own stack and gains)."""
        if isinstance(command, cmd.RobotCommand):
            knobs = self.realism.knobs  # a preset is the new robot's own
            if knobs.preset in REALISM_PRESETS:
                knobs = preset(knobs.preset, command.name)
            return replace(
                self._live_config(), robot=command.name, stack=None, gains={}, realism=knobs
            )
        return replace(self._live_config(), scene=command.name)

    def install(self, parts: SessionParts) -> SessionParts:
        """Swap in parts built beside the loop for a switch (`build_parts`); the old parts."""
        old = self._install(parts)
        self._event("session_rebuilt", f"robot {self.config.robot} in scene {self.config.scene}")
        return old

    def _reset_state(self, time: float = 0.0) -> None:
        """The robot standing under control at sim time `time` (s), nothing commanded."""
        self.plant.reset(self.robot.q_standing, time=time)
        self.plant.set_joint_damping(0.0)
        self.realism.reset(self.robot.q_standing)
        self._true_state = self.plant.state()  # this tick's, read by _measure
        self.estimator.reset(*self._true_state)
        self.controller.forget_last_solution()  # the last tick's was of the state left behind
        self._set_behaviour(Balance.name)
        # the hands task's targets: each hand held where it stands (a `hand` command moves them)
        self.hands = HandTargets.holding(
            self.robot.model, self.robot.q_standing, self.robot.description.hands
        )
        self.pushes: dict[str, Push] = {}
        self.velocity = np.zeros(3)
        self.paused = False
        self.fell = False
        self._non_foot_contact_since: float | None = None
        self.ticks = 0
        self.qp_ok = True
        self._failure = ""  # why the last failed tick failed
        self._output: ControlOutput | None = None  # the last tick's, None after a fallback
        self._unreported = dict.fromkeys(STATUS_EVENTS.values(), 0)
        self._last_report = dict.fromkeys(self._unreported, -FAILURE_EVENT_PERIOD)
        self.control_us = 0.0
        self.tau = np.zeros(self.model.na)
        self.applied_tau = np.zeros(self.model.na)  # what the drives applied last tick (N m)
        self.forces = np.zeros(self.model.nf)
        self._last_divergence = -DIVERGENCE_REPEAT_S
        self._warnings: dict[str, ControllerWarning] = {}  # by category name
        self._capture = WarningCapture()  # every tick's warnings, for telemetry

    def _set_behaviour(self, name: str, options: dict | None = None) -> dict:
        """Start behaviour `name` from the current state, with walking `options` (step_height,
        cycle_time, footholds) if any; a walking behaviour continues the previous one in stride.
        A behaviour that lifts feet on a stack without `swing_feet` brings its `stack_preset`
        along, or WALKING_PRESET (returned as the reply's `preset` and `stack`). Raises KeyError
        or ValueError for an unknown name or a bad option, changing nothing."""
        if name not in BEHAVIOURS:
            raise KeyError(f"unknown gait {name!r} (gaits: {', '.join(BEHAVIOURS)})")
        self.model.update(*self.plant.state())
        behaviour = BEHAVIOURS[name](self.model, self.robot.q_standing)
        footholds = self.robot.description.footholds
        if footholds is not None and name in WALKING_BEHAVIOURS:
            options = {"footholds": footholds, **(options or {})}
        if options:
            behaviour.configure(**options)
        if self.behaviour is not None:
            behaviour.continue_from(self.behaviour)
        walking_stack = behaviour.lifts_feet and (
            "swing_feet" not in self.controller.config.stack.names()
        )
        self.behaviour = behaviour
        self.controller.references = behaviour.references
        if not walking_stack:
            return {}
        reply = self._use_preset(behaviour.stack_preset or WALKING_PRESET)
        self._gait_stack = reply["stack"]
        return reply

    def _use_preset(self, name: str) -> dict:
        """Install stack preset `name`: its levels, its tasks' gains, its hierarchy method.
        Raises KeyError for an unknown name, changing nothing."""
        preset = load_stack_preset(name)
        stack = Stack.of(preset.levels)
        self.controller.set_stack(stack)  # presets name known tasks: this cannot fail halfway
        for task, gains in preset.gains.items():
            self.controller.set_gains(task, **gains)
        self.controller.set_hierarchy(preset.method)
        return {
            "preset": name,
            "stack": stack.as_lists(),
            "hierarchy": hierarchy_report(self.controller),
        }

    @property
    def time(self) -> float:
        return self.plant.time

    # ----------------------------------------------------------------------------- the tick
    def tick(self) -> None:
        """Advance one control period: read state, control, write torques, one MuJoCo step.
        A state that is not valid before or after the step is a divergence (`_recover`). The
        whole tick is one crossing into C++ (native_tick.py) when the plant, the controller and
        the behaviour allow; else, and when `native_ticks` is False, the Python path below runs
        and `tick_note` says why."""
        if self.paused:
            return
        self._expire_pushes()
        controller, behaviour = self.controller, self.behaviour
        # An idle behaviour's update changes nothing (Balance off a foot line): the model update
        # and the solve are then one call (one crossing on the native kernel), no touch sensing.
        idle = behaviour.idle and not controller.reads_sensing
        if not self.native_ticks:
            self.tick_note = "native ticks are off (Session.native_ticks)"
        elif not self.fell and self.estimator.filter is not None:
            self.tick_note = (
                f"the state estimator ({self.estimator.name}) runs in Python (realism.md)"
            )
        elif not self.fell and (not self.realism.ideal or self.realism.knobs.contact_estimate):
            # the realism seams and the touch estimate are on the Python path (realism.md)
            self.tick_note = "the realism layer runs between plant and controller (realism.md)"
        else:
            self.tick_note = self.native_tick.note(behaviour, idle, self.fell)
        native = False  # whether the native tick stepped (it made the fall check's contact test)
        try:
            if not self.tick_note and (stepped := self._control(idle, native=True)) is not None:
                if stepped is TickStatus.DIVERGED_AFTER:
                    self.plant.check()  # raises, naming the cause, as the Python step does
                native = True
                self.applied_tau = self.tau  # the native tick applied them (realism ideal)
            else:  # the Python tick, or the fallback torques of a failed native control
                if self.tick_note:
                    self.plant.check()  # a state set from outside (fault injection) first
                    if self.fell:  # torques off until a reset, as a fall protection does; the
                        self.model.update(*self.plant.state())  # model follows (telemetry)
                    else:
                        self._control(idle, native=False)
                self.applied_tau = self.tau if self.fell else self._actuated()
                self.plant.set_torques(self.applied_tau)
                self.plant.step()
        except SimulationDiverged as divergence:
            self._recover(divergence)
            return
        self.ticks += 1
        if (
            self.ticks % FALL_CHECK_PERIOD == 0
            and not self.fell
            and self._fallen(self.native_tick.non_foot_contact if native else None)
        ):
            self.fell = True
            self.tau, self.forces = np.zeros_like(self.tau), np.zeros_like(self.forces)
            self.applied_tau = self.tau
            self.plant.set_joint_damping(self.robot.torque_limits / LIMP_DAMPING_SPEED)
            self.pushes.clear()
            self.plant.clear_push()
            self.velocity = np.zeros(3)  # a robot stood up again must not walk off
            self._event(
                "fall",
                "the robot fell: torques off, joints damped, pushes ended and velocity zeroed "
                "until reset",
            )

    # The realism seams (lab/realism, docs/realism.md): the controller reads `_measure`'s
    # state, the plant applies `_actuated`'s torques; the `estimator` knob's EKF sits in `_measure`.
    def _measure(self) -> tuple[np.ndarray, np.ndarray]:
        """The state the controller reads this tick: the true one through the realism layer's
        measurement delay, IMU and encoders (the true one when the layer is ideal), its base
        estimated by the EKF when the `estimator` knob says so (world/estimator.py)."""
        self._true_state = truth = self.plant.state()
        measured = truth if self.realism.ideal else self.realism.measure(*truth)
        contacts = self.controller.references.contact_active  # the controller's (last tick's)
        return self.estimator.read(truth, measured, contacts)

    def _actuated(self) -> np.ndarray:
        """The joint torques the drives apply for the controller's `tau` (N m): the command
        delay and actuator model of the realism layer (`tau` itself when it is ideal)."""
        return self.tau if self.realism.ideal else self.realism.actuate(self.tau, *self._true_state)

    def _touch_from_torques(self, flags: np.ndarray) -> np.ndarray:
        """Which feet touch, from the contact forces estimated from last tick's applied torques
        at this tick's model (Raiola eq. 18); a foot it cannot estimate keeps its `flags`."""
        normal = estimated_contact_forces(self.model, self.applied_tau)[:, 2]
        share = self.model.mass * 9.81 / len(self.model.contacts)
        return np.where(np.isnan(normal), flags, normal > ESTIMATED_TOUCH_FRACTION * share)

    def _control(self, idle: bool, native: bool) -> TickStatus | None:
        """This tick's torques and planned contact forces: the controller's, or fallback ones.
        `native`: the whole tick in one crossing (native_tick.py), which also applies the
        torques and steps; returns how it ended when it did (None when the controller failed:
        the caller applies the fallback torques, or when not `native`). Raises
        SimulationDiverged when the state was not valid before control."""
        controller, behaviour = self.controller, self.behaviour
        if self.hands.targets:
            self.hands.write(controller.references, self.time)
        stepped = None
        with self._capture as caught:
            try:
                if native:
                    stepped, out = self.native_tick.run(
                        behaviour, idle, self.velocity, self.tau, TOUCH_FORCE
                    )
                else:
                    q, v = self._measure()
                    # sensing, not control
                    touching = None if idle else self.plant.feet_touching(TOUCH_FORCE)
                    start = time.perf_counter()
                    if idle:
                        out = controller.compute(q, v)
                    else:
                        controller.update(q, v)
                        if self.realism.knobs.contact_estimate:
                            touching = self._touch_from_torques(touching)
                        if controller.reads_sensing:  # measured only for a task that reads it
                            controller.set_sensing(self.plant.foot_forces(), self.tau)  # Kim 12
                        behaviour.update(self.time, self.model, self.velocity, touching)
                        out = controller.solve()
                if not out.torques_finite():
                    raise FloatingPointError("non-finite torques")
                self.tau, self.forces, self.qp_ok = out.tau, out.forces, True
                self._output = out
                status = out.solve_status()
                if status is not SOLVED:
                    extra = {"levels": list(out.fallback_levels)} if out.fallback_levels else {}
                    self._report(
                        STATUS_EVENTS[status.status],
                        status.reason,
                        self._control_time(native),
                        status=status.status,
                        level=status.level,
                        **extra,
                    )
            except SimulationDiverged:
                raise
            except (ArithmeticError, np.linalg.LinAlgError, RuntimeError) as error:
                if native:  # the native tick did not step: the plant is at this tick's state
                    q, v = self.plant.state()
                self.tau, self.forces = self._fallback_torques(q, v), 0 * self.forces
                self.qp_ok, self._output = False, None
                self.qp_failures += 1
                self._failure = f"{type(error).__name__}: {error}; fallback torques"
                self._report(
                    "solver_failure",
                    self._failure,
                    self._control_time(native),
                    status="failed",
                    level=None,
                )
        ran = controller.ran
        self.ran_ticks[ran] = self.ran_ticks.get(ran, 0) + 1
        self.control_us = (
            self.native_tick.control_us if native else (time.perf_counter() - start) * 1e6
        )
        for caught_warning in caught:
            kind = caught_warning.category.__name__
            count = self._warnings[kind].ticks + 1 if kind in self._warnings else 1
            message, t = str(caught_warning.message), self._control_time(native)
            self._warnings[kind] = ControllerWarning(message, t, count)
        return stepped

    def _control_time(self, native: bool) -> float:
        """The sim time this tick controlled at: the native tick has stepped already."""
        return self.native_tick.tick_time if native else self.time

    def tick_report(self) -> dict:
        """Which path ran the last tick: `native` (one crossing) or `python`, and why."""
        return {"tick": "python" if self.tick_note else "native", "tick_note": self.tick_note}

    @property
    def status(self) -> SolveStatus:
        """The last tick's status: `failed` (fallback torques) with the error, or how the
        hierarchy found x (ok before the first tick)."""
        if not self.qp_ok:
            return SolveStatus("failed", None, self._failure)
        return SOLVED if self._output is None else self._output.solve_status()

    @property
    def solution(self) -> HierarchySolution | None:
        """The last tick's hierarchy solution (built when read), None after a fallback."""
        return None if self._output is None else self._output.solution

    def _recover(self, divergence: SimulationDiverged) -> None:
        """After a divergence: the robot standing again at the same sim time (the clock never runs
        backwards); a second divergence within DIVERGENCE_REPEAT_S also pauses until `reset`."""
        repeated = divergence.time - self._last_divergence < DIVERGENCE_REPEAT_S
        self._reset_state(time=divergence.time)
        self._last_divergence = divergence.time
        self.divergences += 1
        self.paused = repeated
        then = (
            f"again within {DIVERGENCE_REPEAT_S:g} s: paused until reset"
            if repeated
            else "robot reset to standing"
        )
        self._event(
            "sim_diverged",
            f"the simulation diverged ({divergence.cause}); {then}",
            cause=divergence.cause,
            restored="paused" if repeated else "standing",
        )

    def _report(self, kind: str, message: str, at: float, **extra: object) -> None:
        """One event of `kind` (a value of STATUS_EVENTS) per FAILURE_EVENT_PERIOD at most, with
        the count of ticks since the last one; `at`: the sim time of the tick it concerns."""
        self._unreported[kind] += 1
        if at - self._last_report[kind] >= FAILURE_EVENT_PERIOD:
            self._event(kind, message, at, count=self._unreported[kind], **extra)
            self._unreported[kind] = 0
            self._last_report[kind] = at

    def _fallback_torques(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Joint PD to the reference posture plus the bias forces: safe for one or a few ticks."""
        gains = self.controller.posture_gains()
        refs = self.controller.references
        bias = self.model.h[BASE_DOF:] if np.all(np.isfinite(self.model.h)) else 0.0
        tau = bias + gains.kp * (refs.posture - q[7:]) - gains.kd * v[BASE_DOF:]
        tau = np.nan_to_num(tau)
        return np.clip(tau, -self.robot.torque_limits, self.robot.torque_limits)

    def _fallen(self, non_foot_contact: bool | None = None) -> bool:
        """Whether the robot fell: too low, too tilted, or a body other than a foot on the
        terrain too long; `non_foot_contact`: that test's answer when the native tick made it
        (None: ask the plant)."""
        # the lab judges the true state (pinocchio conventions: quaternion x, y, z, w); with the
        # realism layer ideal, the model's state is it
        exact = self.realism.ideal and self.estimator.filter is None
        q = self.model.q if exact else self._true_state[0]
        height = q[2]
        upright = 1.0 - 2.0 * (q[3] ** 2 + q[4] ** 2)  # z of the base z axis, from the quaternion
        tilt = math.acos(min(1.0, max(-1.0, float(upright))))
        if non_foot_contact is None:
            non_foot_contact = self.plant.non_foot_ground_contact()
        if not non_foot_contact:
            self._non_foot_contact_since = None
        elif self._non_foot_contact_since is None:
            self._non_foot_contact_since = self.time
        return (
            height < FALL_HEIGHT_FRACTION * self.robot.q_standing[2]
            or tilt > FALL_TILT
            or (
                self._non_foot_contact_since is not None
                and self.time - self._non_foot_contact_since >= FALL_CONTACT_S
            )
        )

    def _expire_pushes(self) -> None:
        if not self.pushes:
            return
        expired = [name for name, p in self.pushes.items() if self.time >= p.ends_at]
        if not expired:
            return
        for name in expired:
            del self.pushes[name]
        self.plant.clear_push()
        for p in self.pushes.values():
            self.plant.push(p.body, p.force, p.point)

    def _event(self, kind: str, message: str, at: float | None = None, **extra: object) -> None:
        """Record an event at sim time `at` (None: now)."""
        t = self.time if at is None else at
        self._events.append({"type": kind, "t": t, "message": message, **extra})
        del self._events[:-MAX_EVENTS]

    def pop_events(self) -> list[dict]:
        events, self._events = self._events, []
        return events

    # ----------------------------------------------------------------------------- commands
    def handle(self, verb: str, payload: object = None) -> dict:
        """Validate and apply one command; never raises. Rejected commands change nothing."""
        try:
            command = cmd.parse_command(verb, {} if payload is None else payload)
        except cmd.CommandError as error:
            return self.refuse(verb, str(error))
        return self.execute(verb, command)

    def execute(self, verb: str, command: cmd.Command) -> dict:
        """Apply one command already validated by `parse_command` (the sim process validates
        off the loop: lab/runtime/intake.py); never raises. What the session refuses (an
        unknown name, a stack it cannot run) changes nothing."""
        try:
            reply = self._apply(command)
        except (cmd.CommandError, StackError, KeyError, ValueError) as error:
            message = error.args[0] if isinstance(error, KeyError) and error.args else str(error)
            return self.refuse(verb, str(message))
        return {"ok": True, **reply}

    def refuse(self, verb: str, message: str) -> dict:
        """The reply refusing a command (`message` says why), reported as `rejected_command`;
        every error reply starts with the verb (a name the session does not know, ...)."""
        if not message.startswith(f"{verb}:"):
            message = f"{verb[:64]}: {message}"
        self._event("rejected_command", message, verb=verb[:64], error=message)
        return {"ok": False, "error": message}

    def _apply(self, command: cmd.Command) -> dict:
        """Apply `command`: one case per command struct (lab.protocol.commands)."""
        match command:
            case cmd.InfoCommand():
                return self.info()
            case cmd.VelocityCommand(vx=vx, vy=vy, yaw_rate=yaw_rate):
                self.velocity = np.array([vx, vy, yaw_rate])
                return {}
            case cmd.PushCommand(body=body, force=force, duration=duration, point=point):
                self._push(
                    body, np.array(force), duration, None if point is None else np.array(point)
                )
                return {}
            case cmd.RobotCommand() | cmd.SceneCommand():
                old = self.install(build_parts(self.switch_config(command)))
                del old  # the old session's parts, freed here...
                release_free_memory()  # ...and the heap they took given back (memory.py)
                return {}
            case cmd.HierarchyCommand(
                method=method, solver=solver, formulation=formulation, kernel=kernel
            ):
                if kernel is not None and kernel not in KERNELS:  # a rejection changes nothing
                    raise KeyError(f"unknown kernel {kernel!r} (kernels: {', '.join(KERNELS)})")
                method = method or self.controller.config.method
                self.controller.set_hierarchy(method, solver, formulation)
                self.controller.set_kernel(kernel or self.controller.config.kernel)
                return {"hierarchy": hierarchy_report(self.controller)}
            case cmd.StackCommand(preset=str(preset)):
                return self._use_preset(preset)
            case cmd.StackCommand(levels=levels):
                stack = Stack.of(levels)
                self.controller.set_stack(stack)
                return {"stack": stack.as_lists()}
            case cmd.GainsCommand(task=task, kp=kp, kd=kd, weight=weight):
                gains = self.controller.set_gains(task, kp, kd, weight)
                return {"task": task, "kp": gains.kp, "kd": gains.kd, "weight": gains.weight}
            case cmd.FloorCommand():
                raise cmd.CommandError("floor: this session has no realtime loop (`lab serve`)")
            case cmd.RecordCommand():
                raise cmd.CommandError(
                    "record: this session has no recorder (`lab serve` records; `lab run` takes "
                    "--record FILE)"
                )
            case cmd.ResetCommand():
                restored = self._standing_stack()
                self._reset_state()
                note = f"; {restored}" if restored else ""
                self._event("reset", f"reset to the standing posture{note}")
                return {"stack": self.controller.config.stack.as_lists()} if restored else {}
            case cmd.PauseCommand():
                self.paused = True
                return {}
            case cmd.ResumeCommand():
                self.paused = False
                return {}
            case cmd.GaitCommand(name=name) as gait:
                options = {
                    key: getattr(gait, key)
                    for key in ("step_height", "cycle_time", "footholds")
                    if getattr(gait, key) is not None
                }
                return self._set_behaviour(name, options)
            case cmd.InternalForceCommand(reference=reference, source=source):
                task = self.controller.internal_force
                if source is not None:
                    task.set_source(source)  # ValueError names the sources, changes nothing
                if reference is not None:
                    task.reference = reference
                return {"internal_force": internal_force_report(self.controller)}
            case cmd.MomentumCommand(mode=mode):
                self.controller.set_momentum_mode(mode)  # ValueError names the modes
                gain = momentum_gain_report(self.controller)
                return {"momentum": {**momentum_report(self.controller), "gain": gain}}
            case cmd.StanceCommand(side=side, swing=swing):
                return self._stance(side, swing)
            case cmd.HandCommand() as hand:
                return {"hand": self.hands.command(hand, self.time)}  # KeyError names the hands
            case cmd.RealismCommand(preset=name) as realism:
                return self._set_realism(name, realism.knobs())
            case cmd.PayloadCommand(body=body, mass=mass, offset=offset):
                self.plant.set_payload(body, mass, np.array(offset))  # KeyError names bodies
                return {"payloads": dict(self.plant.payloads)}
            case cmd.TakeCommand() | cmd.ReleaseCommand():  # one user: nothing to lock
                return {}
            case _:  # a command struct without a case here: mypy names it
                assert_never(command)

    def _set_realism(self, name: str | None, values: dict) -> dict:
        """Run realism preset `name` (None: the knobs running now) with `values` over it. A
        new model error rebuilds the session's parts (the robot stands again); other knobs
        replace the realism layer and the drive limits at once. Raises ValueError naming a bad
        knob, changing nothing."""
        knobs = knobs_from(preset(name, self.config.robot) if name else self.realism.knobs, values)
        if knobs.model_error != self.realism.knobs.model_error:
            old = self.install(build_parts(replace(self._live_config(), realism=knobs)))
            del old
        else:
            self.realism = realism_layer(knobs, self.model.na, self.config.timestep)
            self.plant.set_drive_limits(
                knobs.torque_saturation, knobs.coulomb_friction, knobs.viscous_friction
            )
            self.realism.reset(self._true_state[0], self.tau)
            self.estimator = BaseEstimator(knobs, self.robot, self.config.timestep)
            self.estimator.reset(*self.plant.state())  # the filter starts at the truth
        return {"realism": self.realism.knobs.values()}

    def _stance(self, side: str | None, swing: float | None = None) -> dict:
        """Stand on both soles or on `side` (Herzog §5.4, behaviours/stance.py; None: where it
        stands), swinging the lifted leg at `swing` Hz if given; starts the stance behaviour,
        with STANCE_PRESET if the stack has no `swing_sole` (or no `swing_leg` for a swing).
        Raises ValueError for a robot without two flat soles or an unknown side, changing
        nothing."""
        contacts = self.model.contacts
        if len(contacts) != 2 or any(contact.kind != "flat" for contact in contacts):
            raise ValueError(f"stance: robot {self.config.robot!r} is not a biped with flat soles")
        reply: dict = {}
        if not isinstance(self.behaviour, Stance):
            self.model.update(*self.plant.state())
            behaviour = Stance(self.model, self.robot.q_standing)
            if side is not None:
                behaviour.request(side)  # raises before anything changes
            self.behaviour = behaviour
            self.controller.references = behaviour.references
        elif side is not None:
            self.behaviour.request(side)
        if swing is not None:
            self.behaviour.swing(swing)
        names = self.controller.config.stack.names()
        if "swing_sole" not in names or (self.behaviour.swing_hz and "swing_leg" not in names):
            reply = self._use_preset(STANCE_PRESET)
        return {"stance": side or self.behaviour.stance, "swing": self.behaviour.swing_hz, **reply}

    def _standing_stack(self) -> str:
        """Before a reset to standing: a stack that a walking gait brought along (and nobody
        edited since) gives way to the robot's default stack, gains and the session's method,
        which stand (Bolt fell 1.4 s after every Reset under biped_step's kim_stepping: no CoM
        task). What was done, or "" when the stack stays."""
        stack = self.controller.config.stack.as_lists()
        if self._gait_stack is None or stack != self._gait_stack:
            return ""
        description = self.robot.description
        self.controller.set_stack(Stack.of(description.stack))
        for task, gains in description.gains.items():
            self.controller.set_gains(task, gains.kp, gains.kd, gains.weight)
        self.controller.set_hierarchy(self.config.method)
        self._gait_stack = None
        return "the walking stack gave way to the robot's default stack, which stands"

    def _push(
        self, body: str, force: np.ndarray, duration: float, point: np.ndarray | None
    ) -> None:
        self.plant.push(body, force, point)  # raises KeyError naming the known bodies
        self.pushes[body] = Push(body, force, point, self.time + duration)

    def _live_config(self) -> SessionConfig:
        """The session's config with the controller's current choices, which the controller
        alone holds while the session runs: what a rebuild for a new scene or robot keeps."""
        live = self.controller.config
        return replace(
            self.config,
            method=live.method,
            solver=live.solver,
            formulation=live.formulation,
            stack=live.stack.as_lists(),
            kernel=live.kernel,
            realism=self.realism.knobs,
        )

    # ----------------------------------------------------------------------------- reports
    def info(self) -> dict:
        return {
            "robots": list(ROBOT_NAMES),
            "scenes": list(SCENES),
            "methods": list(METHODS),
            "solvers": list(SOLVERS),
            "formulations": list(FORMULATIONS),
            "momentum_modes": list(MOMENTUM_MODES),
            "kernels": list(KERNELS),
            "gaits": list(BEHAVIOURS),
            "stack_presets": list(PRESET_NAMES),
            "robot": self.config.robot,
            "scene": self.config.scene,
            "gait": self.behaviour.name,
            "momentum": {
                **momentum_report(self.controller),
                "gain": momentum_gain_report(self.controller),
            },
            "hierarchy": hierarchy_report(self.controller),
            "kernel": self.controller.config.kernel,
            **self.tick_report(),
            "stack": self.controller.config.stack.as_lists(),
            "known": list(self.controller.known_names),
            "tasks": task_gains_report(self.controller),
            "bodies": list(self.plant.body_names),
            "base": self.robot.base_link,
            "mass": self.model.mass,
            "contacts": [c.name for c in self.robot.contacts],
            "hands": self.hands.report(),
            "paused": self.paused,
            "realism": self.realism.knobs.values(),
            "payloads": dict(self.plant.payloads),
            "t": self.time,
        }

    def telemetry(self) -> dict:
        """Everything the UI plots and the tests check, JSON-ready (see docs/protocol.md)."""
        return telemetry_message(self)

    def telemetry_in_two(self) -> tuple[dict, Callable[[], None]]:
        """`telemetry` in two steps, for two ticks of the realtime loop: the message with this
        tick's state now, `finish` fills in the rest later (`telemetry.telemetry_in_two`)."""
        return telemetry_in_two(self)

    def recent_warnings(self) -> list[dict]:
        """The controller's warnings (e.g. nullspace's active-set cap) raised within the last
        WARNING_HOLD_S of sim time, one entry per kind (telemetry's `controller_warnings`)."""
        return [
            {"kind": kind, "message": w.message, "t": w.t, "ticks": w.ticks}
            for kind, w in self._warnings.items()
            if self.time - w.t <= WARNING_HOLD_S
        ]

    def drawing_state(self) -> dict:
        """What the UI needs to draw the robot (`lab/state`)."""
        return state_message(self)

    def base_orientation_error(self) -> float:
        """Angle (rad) between the base and its reference orientation."""
        R_ref = self.controller.references.base_rotation
        return float(np.linalg.norm(pin.log3(R_ref.T @ self.model.base_rotation)))
