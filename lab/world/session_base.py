"""What every part of a session stands on (`SessionBase`): its parts installed, the robot
reset to standing with nothing commanded, the behaviour and the stack preset it brings, the
events. The tick (session_tick.py), the commands (session_commands.py) and the reports
(session.py) are layered on it, in that order: `Session` is the last of them.
"""

from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from typing import TYPE_CHECKING

import numpy as np

from lab import protocol as cmd
from lab.controller.behaviours import BEHAVIOURS, Balance, Behaviour
from lab.controller.behaviours.walking import WALKING_BEHAVIOURS
from lab.controller.controller import ControlOutput, Ran
from lab.controller.momentum import GainFuture, LqrProblem
from lab.controller.stack import Stack
from lab.realism.contact_estimate import TouchThresholds
from lab.realism.knobs import PRESET_NAMES as REALISM_PRESETS
from lab.realism.knobs import preset
from lab.stack_presets import load_stack_preset
from lab.world.session_parts import SessionConfig, SessionParts, build_parts
from lab.world.telemetry import hierarchy_report
from lab.world.touch_estimate import TouchEstimate
from lab.world.warning_capture import WarningCapture

if TYPE_CHECKING:
    from lab.world.plain_tick import TickPlan

MAX_EVENTS = 256  # events kept for pop_events; older ones are dropped
FAILURE_EVENT_PERIOD = 0.5  # s of sim time between two solver_failure events
# The event each status other than ok raises (at most one per FAILURE_EVENT_PERIOD each).
STATUS_EVENTS = {
    "failed": "solver_failure",
    "fallback": "solver_fallback",
    "capped": "solver_capped",
    "violated": "solver_violation",
}
# s: a sim divergence this soon after the previous one pauses the session instead of resetting
# the robot again (a diverging set-up would otherwise reset it every few ticks).
DIVERGENCE_REPEAT_S = 1.0
# The stack a gait that lifts feet brings along when the current one has no swing_feet task
# (a robot's default stack is for standing): Raiola's S3, the stack of the trot scenarios.
WALKING_PRESET = "raiola_s3"


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


class SessionBase(SessionParts):
    """A session's parts (SessionParts, which declares them: swapped in together by
    `install`) and the state of its run (module docstring); `Session` is the whole.
    `gain_designer`, when given (`lab serve`: a worker process, gain_designer.py), designs the
    momentum task's LQR gains off the loop; headless sessions design them at once."""

    def __init__(
        self,
        config: SessionConfig | None = None,
        gain_designer: Callable[[LqrProblem], GainFuture] | None = None,
    ) -> None:
        self._gain_designer = gain_designer
        self._events: list[dict] = []
        self.divergences = 0  # sim divergences since the session started
        # ticks computed by each (kernel, method, solver, formulation), since the session
        # started (`ran_ticks`): the current run of ticks of one Ran is counted apart and
        # folded in when it changes or the counts are read (a Ran's hash is Python's: 0.5 µs)
        self._ran_ticks: dict[Ran, int] = {}
        self._ran_run: Ran | None = None
        self._ran_run_ticks = 0
        # ticks whose controller failed since the session started (telemetry's qp.failures):
        # a reset or a robot switch does not clear it, so it never reads fewer than the
        # solver_failure events seen (the soak's report once said 0 beside 35 of them)
        self.qp_failures = 0
        # False: every tick runs the Python path (the reference the native tick is held to)
        self.native_ticks = True
        self.tick_note = ""  # why the last tick ran the Python path ('' when it ran native)
        self._install(build_parts(config or SessionConfig()))  # raises on bad names

    @property
    def ran_ticks(self) -> dict[Ran, int]:
        """Ticks computed by each (kernel, method, solver, formulation) since the session
        started."""
        self._fold_ran_run()
        return self._ran_ticks

    def _count_ran(self, ran: Ran) -> None:
        """One more tick computed by `ran`."""
        if ran is not self._ran_run:
            self._fold_ran_run()
            self._ran_run = ran
        self._ran_run_ticks += 1

    def _fold_ran_run(self) -> None:
        if self._ran_run is not None and self._ran_run_ticks:
            ran = self._ran_run
            self._ran_ticks[ran] = self._ran_ticks.get(ran, 0) + self._ran_run_ticks
        self._ran_run_ticks = 0

    # ----------------------------------------------------------------------------- set-up
    def _install(self, parts: SessionParts) -> None:
        """Take `parts` as the session's (the robot standing, nothing commanded)."""
        for part in fields(SessionParts):  # a copy, field by field
            setattr(self, part.name, getattr(parts, part.name))
        self.controller.set_momentum_designer(self._gain_designer)
        self._gait_stack: list[list[str]] | None = None  # the levels a gait brought along
        self._restart(parts.behaviour)  # the parts stand already (`build_parts`)

    def parts(self) -> SessionParts:
        """The parts running now, apart from the session: what `install` hands back."""
        return SessionParts(
            **{part.name: getattr(self, part.name) for part in fields(SessionParts)}
        )

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
        """Swap in parts built beside the loop for a switch (`build_parts`); the old parts, for
        the caller to drop where it likes (a thread beside the loop frees them there,
        lab/runtime/switch.py)."""
        old = self.parts()
        self._install(parts)
        self._event("session_rebuilt", f"robot {self.config.robot} in scene {self.config.scene}")
        return old

    def _reset_state(self, time: float = 0.0) -> None:
        """The robot standing under control at sim time `time` (s), nothing commanded."""
        self.stand(time)  # the last tick's solution forgotten: it was of the state left behind
        self._restart()

    def _restart(self, standing: Behaviour | None = None) -> None:
        """The run anew, nothing commanded, from the parts standing at rest (`stand`).
        `standing`: the parts' own `Balance`, made by `build_parts` for the robot standing at
        rest, as it is here: a switch's swap then does not make one on the loop (1 ms)."""
        self._true_state = self.plant.state()  # this tick's, read by _measure
        if standing is None:
            self._set_behaviour(Balance.name)
        else:
            self.behaviour = standing
            self.controller.references = standing.references
        self.pushes: dict[str, Push] = {}
        self.velocity = np.zeros(3)
        self.paused = False
        self.fell = False
        self._non_foot_contact_since: float | None = None
        self.ticks = 0
        self.qp_ok = True
        self._failure = ""  # why the last failed tick failed
        # The tick's path, decided when what it depends on changes (plain_tick.py's TickPlan:
        # None until the next tick decides it), the plan of a plain native tick whose results
        # are still in the kernel's buffers (None when copied out), and a native crossing made
        # already whose code or error the rest of the tick handles.
        self._plan: TickPlan | None = None
        self._pending: TickPlan | None = None
        self._crossing: int | BaseException | None = None
        self._output: ControlOutput | None = None  # the last tick's, None after a fallback
        self._unreported = dict.fromkeys(STATUS_EVENTS.values(), 0)
        self._last_report = dict.fromkeys(self._unreported, -FAILURE_EVENT_PERIOD)
        self.control_us = 0.0
        self.tau = np.zeros(self.model.na)
        self.applied_tau = np.zeros(self.model.na)  # what the drives applied last tick (N m)
        self._start_touch_estimate()
        self.forces = np.zeros(self.model.nf)
        self._last_divergence = -DIVERGENCE_REPEAT_S
        self._warnings: dict[str, ControllerWarning] = {}  # by category name
        self._capture = WarningCapture()  # every tick's warnings, for telemetry

    def _start_touch_estimate(self) -> None:
        """Realism's touch detector anew when `contact_estimate` is on, in both tick paths
        (touch_estimate.py); None, MuJoCo's contact flags, when it is off."""
        self.touch_estimate: TouchEstimate | None = None
        self.native_tick.set_touch_estimator(None)
        if self.realism.knobs.contact_estimate:
            self.touch_estimate = TouchEstimate(
                TouchThresholds(**self.robot.description.touchdown),
                self.config.timestep,
                self.model.na,
                len(self.model.contacts),
                self.native_tick,
                self.applied_tau,
            )

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

    def _event(self, kind: str, message: str, at: float | None = None, **extra: object) -> None:
        """Record an event at sim time `at` (None: now)."""
        t = self.time if at is None else at
        self._events.append({"type": kind, "t": t, "message": message, **extra})
        del self._events[:-MAX_EVENTS]

    def pop_events(self) -> list[dict]:
        events, self._events = self._events, []
        return events

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
