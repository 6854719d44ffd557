"""What makes a plain native tick plain (session_tick.py's `Session.tick`): the path decided
once, not every tick (`TickPlan`), and the tick's results left in the kernel's buffers until read
(`PlainTickResults`).

A plain tick is the server tick's one crossing (native_tick.py) that stepped with the
controller's status ok: the session then only counts it. Deciding the path (the native tick's
`note`: the behaviour, the realism layer, the estimator, the controller's kernel and stack)
and copying τ, x and the controller's report out each tick cost more than the rest of the
Python around the crossing (docs/performance.md, "Where the plain tick goes"); telemetry reads
them at 100 Hz, the loop ticks at 1 kHz.
"""

from typing import Any, Generic, Protocol, TypeVar, overload

import numpy as np

from lab.controller.behaviours.base import Behaviour
from lab.controller.behaviours.native import NativeTick as NativeTwinTick
from lab.controller.behaviours.native import NativeTwin
from lab.controller.controller import ControlOutput
from lab.controller.native import NativeController
from lab.realism.layer import NativeRealismLayer, RealismLayer
from lab.world.estimator import BaseEstimator
from lab.world.native_tick import NativeTick

TOUCH_FORCE = 1.0  # N: a foot pressing on the ground harder than this touches it
T = TypeVar("T")


class PlannedSession(Protocol):
    """What a tick plan reads of its session (session_tick.py's SessionTick), read-only."""

    @property
    def controller(self) -> NativeController: ...
    @property
    def behaviour(self) -> Behaviour: ...
    @property
    def realism(self) -> RealismLayer | NativeRealismLayer: ...
    @property
    def estimator(self) -> BaseEstimator: ...
    @property
    def native_tick(self) -> NativeTick: ...
    @property
    def fell(self) -> bool: ...
    @property
    def native_ticks(self) -> bool: ...
    @property
    def _true_state(self) -> tuple[np.ndarray, np.ndarray]: ...


class TickPlan:
    """Which path the session's tick runs, decided from what it depends on (`holds` checks it
    each tick: identities and names, no work): the session's behaviour, realism layer,
    estimator, fall and `native_ticks`, the controller's references and settings, the native
    tick itself; the session drops its plan on every command (a push, a gait, a stack, ...).
    On the native path it sets the native tick's parts once (NativeTick.set_parts)."""

    def __init__(self, session: PlannedSession) -> None:
        controller, behaviour = session.controller, session.behaviour
        config, realism = controller.config, session.realism
        self.controller, self.behaviour, self.refs = controller, behaviour, controller.references
        self.realism, self.estimator = realism, session.estimator
        self.native_tick = session.native_tick
        self.fell, self.native_ticks = session.fell, session.native_ticks
        self.config = config
        self.settings = (config.kernel, config.method, config.solver, config.formulation)
        self.stack = config.stack
        # An idle behaviour's update changes nothing (Balance off a foot line): the model update
        # and the solve are then one call (one crossing on the native kernel), no touch sensing.
        self.idle = behaviour.idle and not controller.reads_sensing
        if not session.native_ticks:
            self.note = "native ticks are off (Session.native_ticks)"
        elif not session.fell and session.estimator.filter is not None:  # the Python filter's
            self.note = (
                f"the state estimator ({session.estimator.name}) runs in Python (realism.md)"
            )
        else:
            self.note = session.native_tick.note(behaviour, self.idle, session.fell, realism)
        native = self.native_tick
        self.ideal = realism.ideal
        self.estimated = session.estimator.native is not None
        truth = native.true_state  # None where there is no native tick (then unused)
        self.truth = session._true_state if truth is None else truth
        self.twin: NativeTwinTick | None = None
        self.owner: NativeTwin | None = None  # the behaviour whose twin ticks
        # A plain tick: its crossing alone, then a few assignments (session_tick.py's `tick`); a
        # task that senses or takes values back from the kernel runs the whole native path.
        self.plain = False
        self.ran = controller.ran  # what a native tick computes: set below when it runs
        if not self.note:
            self.ran = controller.native_settings()
            native.set_parts(behaviour, self.idle, TOUCH_FORCE, realism, session.estimator)
            self.twin = native.twin
            if self.twin is not None and isinstance(behaviour, NativeTwin):
                self.owner = behaviour
            self.plain = not native.sensing and not controller.reports_to_tasks
        self.step = native.step
        self.outcome = native.outcome
        # The ServerTick itself, read once a plain tick for its valid time (NativeTick's
        # property around it cost 0.4 µs more a tick); None off the native path.
        self.server: Any = None if self.note else native.server

    def holds(self, session: PlannedSession) -> bool:
        """Whether what the plan was made from is what the session runs now. A plan for the
        Python path never holds: a behaviour's twin becomes available after its first Python
        tick (the gait's clock started), and the decision costs little beside a Python tick."""
        controller = session.controller
        config = controller.config
        return (
            not self.note
            and controller is self.controller
            and session.behaviour is self.behaviour
            and controller.references is self.refs
            and session.realism is self.realism
            and session.estimator is self.estimator
            and session.native_tick is self.native_tick
            and session.fell == self.fell
            and session.native_ticks == self.native_ticks
            and config is self.config
            and config.stack is self.stack
            and (config.kernel, config.method, config.solver, config.formulation) == self.settings
        )


class Settled(Generic[T]):
    """One of the last tick's results on `PlainTickResults`, kept in the attribute `slot`: read
    or set, it first copies a pending plain tick's results out of the kernel's buffers
    (`_settle`)."""

    def __init__(self, slot: str, doc: str) -> None:
        self.slot = slot
        self.__doc__ = doc

    @overload
    def __get__(self, results: None, owner: type) -> "Settled[T]": ...
    @overload
    def __get__(self, results: "PlainTickResults", owner: type) -> T: ...
    def __get__(self, results: "PlainTickResults | None", owner: type) -> "T | Settled[T]":
        if results is None:
            return self
        if results._pending is not None:
            results._settle()
        return getattr(results, self.slot)

    def __set__(self, results: "PlainTickResults", value: T) -> None:
        if results._pending is not None:
            results._settle()
        setattr(results, self.slot, value)


class PlainTickResults:
    """The session's τ, F, applied torques, control time and controller output: plain
    attributes on the Python path, copied out of the kernel's buffers when first read after a
    plain native tick (`_pending`: its plan)."""

    controller: NativeController
    native_tick: NativeTick
    _pending: TickPlan | None
    _tau: np.ndarray
    _forces: np.ndarray
    _applied_tau: np.ndarray
    _control_us: float
    _last_output: ControlOutput | None

    tau = Settled[np.ndarray](
        "_tau",
        "The controller's joint torques of the last tick (N m; fallback ones after a failure, "
        "zeros after a fall).",
    )
    forces = Settled[np.ndarray](
        "_forces", "The contact forces the controller planned in the last tick (N, nf of them)."
    )
    applied_tau = Settled[np.ndarray](
        "_applied_tau",
        "What the drives applied in the last tick (N m): τ through the realism layer.",
    )
    _output = Settled[ControlOutput | None](
        "_last_output", "The last tick's controller output, None after a fallback."
    )

    @property
    def control_us(self) -> float:
        """Microseconds the last tick's control took (on the native tick: from the state check
        to the solve's end, in C++)."""
        if self._pending is not None:  # read by `lab bench` every tick: no copies
            return self.native_tick.control_us
        return self._control_us

    @control_us.setter
    def control_us(self, value: float) -> None:
        if self._pending is not None:
            self._settle()
        self._control_us = value

    def _settle(self) -> None:
        """Copy the last plain native tick's results out of the kernel's buffers (its plan says
        whether the realism layer was ideal)."""
        plan, self._pending = self._pending, None
        assert plan is not None  # called only with a plain tick's results pending
        native_tick = self.native_tick
        buffers = native_tick.buffers
        out = self.controller.native_output(buffers["tau"], buffers["x"])
        self._tau, self._forces, self._last_output = out.tau, out.forces, out
        self._applied_tau = out.tau if plan.ideal else native_tick.applied_torques()
        self._control_us = native_tick.control_us
