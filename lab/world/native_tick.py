"""NativeTick: the session's tick in one crossing (`lab._kernel.ServerTick`, server_tick.cpp).

The Python tick (`Session.tick`, `_control`) crosses into C++ eight to twelve times a tick: the
plant's check, state, the realism layer's measurement, touch sensing, the kernel's update, the
behaviour's native tick, the solve, the layer's actuators, the torques and the step.
`ServerTick.tick` (cpp/plant/server_tick.cpp) does them all in that order in one call, on the
plant's MjModel and MjData, the controller's native kernel, the behaviour's native twin
(`NativeTwin`), the session's C++ realism layer (`NativeRealismLayer`, when not ideal) and its
touch detector (touch_estimate.py, when `contact_estimate` is on), and
reports a status code; this module decides when it
can run (`note`) and turns its outcome into what the Python tick leaves behind: the session's τ,
F and output, the plant's bookkeeping, and on a fault the same exceptions (`SimulationDiverged`
from the plant's own check, `QPFailure` from the controller), so the session raises the same
events with the same messages. The Python tick stays the reference (tests/kernel/test_native_tick.py
holds the two equal tick by tick).
"""

from enum import IntEnum

import numpy as np

from lab.controller.behaviours.base import Behaviour
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
    """How a native tick ended (server_tick.cpp's TickStatus)."""

    STEPPED = 0  # controlled, torques applied, stepped, the new state valid
    DIVERGED_BEFORE = 1  # the state was not valid before control: nothing ran
    CONTROL_FAILED = 2  # the controller failed: nothing applied, no step
    DIVERGED_AFTER = 3  # stepped, and the new state is not valid


class NativeTick:
    """The native server tick of one session's plant and controller (module docstring); None
    of it exists where `lab._kernel` lacks the ServerTick (`NOT_BUILT`)."""

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

    def run(
        self,
        behaviour: Behaviour,
        idle: bool,
        command: np.ndarray,
        applied: np.ndarray,
        touch_force: float,
        realism: RealismLayer | NativeRealismLayer,
        estimator: BaseEstimator,
    ) -> tuple[int, ControlOutput]:
        """One tick (`note` said it can run), its state measured and its torques applied
        through `realism` unless that is ideal, its base estimated by `estimator`'s C++ twin
        when it has one (the session's note keeps a Python filter off this path): the status
        (a TickStatus value, as an int: STEPPED, or DIVERGED_AFTER: the caller's
        `plant.check()` then raises, as the Python tick's step does, after the tick's
        bookkeeping) and the controller's output. Raises
        `SimulationDiverged` when the state was not valid before control (the plant's check
        names why) and the controller's QPFailure when it failed: nothing was applied then, the
        caller falls back."""
        controller, plant, tick = self.controller, self.plant, self._tick
        twin = None if idle or not isinstance(behaviour, NativeTwin) else behaviour.native_twin()
        stale = twin is not None and behaviour.native_stale
        sensing = controller.reads_sensing
        # the C++ layer between plant and controller (`note` keeps a Python one off this path)
        layer = (
            realism.native
            if isinstance(realism, NativeRealismLayer) and not realism.ideal
            else None
        )
        ekf = estimator.native  # the feet it reads: the controller's, as Session._measure
        contacts = None if ekf is None else np.asarray(controller.references.contact_active, bool)
        controller.prepare_native_tick()
        try:
            status, outcome = tick.tick(
                controller.references,
                controller.robot,
                behaviour,
                twin,
                stale,
                command,
                applied,
                touch_force,
                sensing,
                layer,
                ekf,
                contacts,
            )
        finally:
            if twin is not None and tick.behaviour_ran:
                behaviour.native_ran()
        # the code as an int: a TickStatus member is an int of the same value (building one
        # every tick cost 0.3-0.7 µs)
        if status == TickStatus.DIVERGED_BEFORE:
            plant.check()  # raises SimulationDiverged naming the cause
        controller.robot.filled_elsewhere()
        if sensing:  # the Python task keeps what was sensed, as set_sensing
            controller.internal_force.measured_forces = self.buffers["foot_forces"].copy()
            controller.internal_force.applied_torques = np.array(applied, dtype=float)
        plant.stepped_elsewhere(tick.valid_time, status != TickStatus.CONTROL_FAILED)
        output = controller.finish_native_tick(outcome, self.buffers["tau"], self.buffers["x"])
        return status, output

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
