"""NativeTick: the session's tick in one crossing (`lab._kernel.ServerTick`, server_tick.cpp).

The Python tick (`Session.tick`, `_control`) crosses into C++ eight to twelve times a tick: the
plant's check, state, the realism layer's measurement, touch sensing, the kernel's update, the
behaviour's native tick, the solve, the layer's actuators, the torques and the step.
`ServerTick.tick` (cpp/plant/server_tick.cpp) does them all in that order in one call, on the
plant's MjModel and MjData, the controller's native kernel, the behaviour's native twin
(`NativeTwin`), the session's C++ realism layer (`NativeRealismLayer`, when not ideal) and its
touch detector (touch_estimate.py, when `contact_estimate` is on), and
reports a status code; this module decides when it
can run (`note`), sets the parts it runs on when they change (`set_parts`: a tick's crossing then
takes only the command), and turns its outcome into what the Python tick leaves behind: the
session's τ, F and output, the plant's bookkeeping, and on a fault the same exceptions
(`SimulationDiverged` from the plant's own check, `QPFailure` from the controller), so the
session raises the same events with the same messages. A plain tick (stepped, the controller's
status ok) leaves τ, F and the controller's report in the kernel's buffers: the session copies
them out when they are read (session_tick.py). The Python tick stays the reference
(tests/kernel/test_native_tick.py holds the two equal tick by tick).
"""

from collections.abc import Callable
from enum import IntEnum

import numpy as np

from lab.controller.behaviours.base import Behaviour
from lab.controller.behaviours.native import NativeTick as NativeTwinTick
from lab.controller.behaviours.native import NativeTwin
from lab.controller.controller import ControlOutput
from lab.controller.native import NativeController
from lab.realism.layer import NativeRealismLayer, RealismLayer
from lab.world.estimator import BaseEstimator
from lab.world.plant import MujocoPlant

try:
    from lab import _kernel
except ImportError:  # not built: every tick runs in Python
    _kernel = None
HAS_SERVER_TICK = _kernel is not None and _kernel.has_server_tick
NOT_BUILT = "" if HAS_SERVER_TICK else "lab._kernel was built without MuJoCo's ServerTick"


class TickStatus(IntEnum):
    """How a native tick ended (server_tick.cpp's TickStatus): the low bits (`STATUS_BITS`) of
    the int `ServerTick.tick` returns."""

    STEPPED = 0  # controlled, torques applied, stepped, the new state valid
    DIVERGED_BEFORE = 1  # the state was not valid before control: nothing ran
    CONTROL_FAILED = 2  # the controller failed: nothing applied, no step
    DIVERGED_AFTER = 3  # stepped, and the new state is not valid


STATUS_BITS = 3  # the TickStatus part of a tick's int
UNSOLVED = 4  # or-ed in: the controller ran and its status is not ok (capped, fallback, violated)
BEHAVIOUR_RAN = 8  # or-ed in: the behaviour's native twin ran


class NativeTick:
    """The native server tick of one session's plant and controller (module docstring); None
    of it exists where `lab._kernel` lacks the ServerTick (`NOT_BUILT`). Its parts (the
    references, the behaviour and its twin, the realism layer, the estimator) are set by `set_parts`
    when they change; `step` is then the crossing alone."""

    def __init__(self, plant: MujocoPlant, controller: NativeController) -> None:
        self.plant, self.controller = plant, controller
        kernel = controller.native_kernel
        self._tick = (
            _kernel.ServerTick(kernel, *plant.native_structs())
            if HAS_SERVER_TICK and kernel is not None and plant.native
            else None
        )
        self.buffers = {} if self._tick is None else self._tick.buffers()
        # the plant's true state before the last tick's step (views: valid until the next tick)
        self.true_state = (self.buffers["q"], self.buffers["v"]) if self.buffers else None
        # One tick on the parts set (`set_parts`): ServerTick.tick(command, reload,
        # applied_torques), its int a TickStatus or-ed with UNSOLVED and BEHAVIOUR_RAN; the
        # caller then makes the Python side current (`finish`, or a plain tick's bookkeeping).
        self.step: Callable[[np.ndarray, bool, np.ndarray | None], int] = (
            self._not_built if self._tick is None else self._tick.tick
        )
        self.twin: NativeTwinTick | None = None  # the behaviour's twin set (None: idle)
        self.sensing = False  # whether a task reads the feet's forces (set_parts)

    def _not_built(self, command: np.ndarray, reload: bool, applied: np.ndarray | None) -> int:
        """`step` where there is no ServerTick: `note` says why, and no tick runs here."""
        raise RuntimeError(f"no native tick: {NOT_BUILT or 'the plant or the controller'}")

    @property
    def server(self) -> "_kernel.ServerTick":
        """The ServerTick, where it is known to exist (`note` said the tick can run here)."""
        assert self._tick is not None
        return self._tick

    def note(
        self,
        behaviour: Behaviour,
        idle: bool,
        fell: bool,
        realism: RealismLayer | NativeRealismLayer,
    ) -> str:
        """Why the next tick runs in Python ('' when it can run here): not built, a fallen robot
        (torques off), the realism layer's Python parts, what the plant's step does in Python,
        the controller, or a behaviour without a native twin."""
        if self._tick is None:
            return NOT_BUILT or "the plant or the controller has no native part"
        if fell:
            return "the robot fell: torques off until reset"
        if not realism.ideal and not isinstance(realism, NativeRealismLayer):
            return "the realism layer is the Python one (realism.md)"
        if note := self.plant.native_step_note or self.controller.server_tick_note:
            return note
        if idle:
            return ""
        if not isinstance(behaviour, NativeTwin) or behaviour.native_twin() is None:
            return f"behaviour {behaviour.name!r} has no native tick here"
        return ""

    def set_parts(
        self,
        behaviour: Behaviour,
        idle: bool,
        touch_force: float,
        realism: RealismLayer | NativeRealismLayer,
        estimator: BaseEstimator,
    ) -> None:
        """Set what the next ticks run on (`note` said they can run here): the controller's
        references, `behaviour` and its twin (none when `idle`), a foot touching when it presses
        harder than `touch_force` (N), the state measured and the torques applied through
        `realism` unless it is ideal, the base estimated by `estimator`'s C++ twin when it has
        one, the feet's forces sensed when a task reads them."""
        controller, tick = self.controller, self.server
        self.twin = (
            None if idle or not isinstance(behaviour, NativeTwin) else behaviour.native_twin()
        )
        self.sensing = controller.reads_sensing
        layer = (
            realism.native
            if isinstance(realism, NativeRealismLayer) and not realism.ideal
            else None
        )
        tick.set_references(controller.references)
        tick.set_behaviour(behaviour, controller.robot, self.twin, touch_force)
        tick.set_measurement(layer, estimator.native, self.sensing)

    def run(
        self, behaviour: Behaviour, command: np.ndarray, applied: np.ndarray
    ) -> tuple[int, ControlOutput]:
        """One tick on the parts set, with the Python side made current (`finish`): the
        status (a TickStatus value: STEPPED, or DIVERGED_AFTER: the caller's `plant.check()`
        then raises, as the Python tick's step does, after the tick's bookkeeping) and the
        controller's output; `command`: [vx, vy, yaw_rate]; `applied`: last tick's torques
        (N m), for a task that senses. Raises as `finish` does."""
        owner = behaviour if self.twin is not None and isinstance(behaviour, NativeTwin) else None
        stale = owner is not None and owner.native_stale
        self.controller.prepare_native_tick()
        try:
            code = self.step(command, stale, applied if self.sensing else None)
        except BaseException:
            self.crossing_raised(owner)
            raise
        return self.finish(code, behaviour, applied)

    def crossing_raised(self, owner: NativeTwin | None) -> None:
        """After a crossing that raised: `owner`, the behaviour whose twin was set, holds the
        twin's state if the twin ran before the error (its Python state is then stale)."""
        if owner is not None and self.behaviour_ran:
            owner.native_ran()

    def finish(
        self, code: int, behaviour: Behaviour, applied: np.ndarray
    ) -> tuple[int, ControlOutput]:
        """After a tick's crossing that returned `code`: the Python side made current (the
        behaviour, the model, the sensed values a task keeps, the plant's bookkeeping); its
        TickStatus and the controller's output. Raises `SimulationDiverged` when the state was not
        valid before control (the plant's check names why) and the controller's QPFailure when
        it failed: nothing was applied then, the caller falls back."""
        if code & BEHAVIOUR_RAN and isinstance(behaviour, NativeTwin):
            behaviour.native_ran()
        status = code & STATUS_BITS
        if status == TickStatus.DIVERGED_BEFORE:
            self.plant.check()  # raises SimulationDiverged naming the cause
        controller = self.controller
        controller.robot.filled_elsewhere()
        if self.sensing:  # the Python task keeps what was sensed, as set_sensing
            controller.internal_force.measured_forces = self.buffers["foot_forces"].copy()
            controller.internal_force.applied_torques = np.array(applied, dtype=float)
        self.plant.stepped_elsewhere(self.valid_time, status != TickStatus.CONTROL_FAILED)
        outcome, buffers = self.server.outcome(), self.buffers
        return status, controller.finish_native_tick(outcome, buffers["tau"], buffers["x"])

    def outcome(self) -> "_kernel.TickOutcome":
        """The controller's report of the last tick (a copy: it stays that tick's)."""
        return self.server.outcome()

    @property
    def valid_time(self) -> float:
        """The sim time (s) of the last state the tick found valid."""
        return self.server.valid_time

    @property
    def behaviour_ran(self) -> bool:
        """Whether the last tick ran the behaviour's native twin."""
        return self.server.behaviour_ran

    def set_touch_estimator(self, estimator: object | None) -> None:
        """The C++ touch detector (`lab._kernel.ContactEstimator`) whose flags the behaviour
        reads from now on instead of MuJoCo's (realism's `contact_estimate`; None: MuJoCo's)."""
        if self._tick is not None:
            self._tick.set_touch_estimator(estimator)

    def applied_elsewhere(self, applied: np.ndarray) -> None:
        """A tick that ran in Python (or reset) applied `applied` (N m): the touch detector
        reads it as last tick's torques."""
        if self._tick is not None:
            self.buffers["applied"][:] = applied

    def applied_torques(self) -> np.ndarray:
        """The joint torques (N m) the plant applied in the last tick that stepped: the
        controller's through the realism layer (a copy)."""
        return self.buffers["applied"].copy()

    @property
    def non_foot_contact(self) -> bool:
        """Whether a body other than a foot touched the terrain after the last tick's step (the
        fall check's contact test)."""
        return self._tick.non_foot_contact

    @property
    def control_us(self) -> float:
        """Microseconds of the last tick from the state check to the solve's end (in C++)."""
        return self._tick.control_seconds * 1e6

    @property
    def tick_time(self) -> float:
        """The sim time (s) the last tick controlled at, before its step."""
        return self._tick.tick_time

    @property
    def call_us(self) -> float:
        """Microseconds of the whole last tick inside C++ (0 when it did not step)."""
        return self._tick.call_seconds * 1e6
