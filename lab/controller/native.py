"""NativeController: the WholeBodyController whose tick can run in the native kernel.

`lab._kernel` (C++, cpp/) computes the same tick as `WholeBodyController.solve` in one call:
pinocchio's model update on the same model (passed through pinocchio's own serialization), the
rows of every task and constraint, the `cascade`, `weighted`, `nullspace` (each of its
formulations) or `wbosc` method, the torques. This class keeps the Python controller as the
source of truth for the stack, the gains, the limits and the references, mirrors them into the
kernel, and picks per tick which kernel runs:
`config.kernel == "native"` runs the native one when it is built and has every name of the stack
and the method; otherwise the Python one runs and `kernel_note` says why (never a silent mix).
What a task holds in Python for the kernel (the momentum task's K_h, the internal force's
setting) crosses through the task's own declared `to_kernel` / `from_kernel` (tasks/base.py):
no task is asked for by name here.

Over 400 lines: most of it is one class, NativeController, whose methods share the kernel it
mirrors into and decide, tick by tick, which kernel ran and why.
"""

import contextlib
import warnings
from collections.abc import Callable

import numpy as np

from lab.controller.controller import (
    ControllerConfig,
    ControlOutput,
    Ran,
    WholeBodyController,
    hierarchy_note,
)
from lab.controller.hierarchy import HierarchySolution
from lab.controller.hierarchy.nullspace import ActiveSetCapWarning
from lab.controller.hierarchy.solution import SOLVED, SolveStatus
from lab.controller.model import RobotModel
from lab.controller.qp import QPFailure
from lab.controller.references import References
from lab.controller.stack import Stack
from lab.controller.tasks import Task, TaskGains
from lab.controller.tasks.momentum import MomentumTask

try:
    from lab import _kernel
except ImportError as error:  # not built: the lab runs on the Python kernel
    _kernel = None
    NOT_BUILT = f"the native kernel is not built ({error})"
else:
    NOT_BUILT = "" if _kernel.has_solvers else "the native kernel was built without its solvers"

KERNELS = ("native", "python")
NATIVE_METHODS = ("cascade", "weighted", "nullspace", "wbosc")
# The kernel compiles DAQP in; Clarabel (a Rust library) is not linked into it: a Clarabel
# request runs on the Python kernel, with a note (docs/controller.md, "Two kernels").
NATIVE_SOLVERS = ("daqp",)


def native_available() -> bool:
    """Whether `lab._kernel` is built with its hierarchy solvers."""
    return not NOT_BUILT


def kernel_for(controller: WholeBodyController, serialized: str | None = None) -> "_kernel.Kernel":
    """A native kernel on the controller's very model (pinocchio's serialization; `serialized`:
    that model's `saveToString()` made already), with its contacts, limits and hands; stack,
    gains and references are set separately."""
    robot, limits = controller.robot, controller.config.limits
    lower, upper = controller.joint_limits()
    kernel = _kernel.Kernel(
        robot.model.saveToString() if serialized is None else serialized,
        [(c.name, c.frame, c.kind, c.radius, c.half_length, c.half_width) for c in robot.contacts],
        controller.torque_limits(),
        lower,
        upper,
        limits.friction,
        limits.normal_min,
        limits.normal_max,
    )
    kernel.set_hands(list(controller.hands), list(controller.hand_joints))
    return kernel


def send_references(kernel: "_kernel.Kernel", refs: References) -> None:
    """Copy the fields of `refs` (References, WalkReferences or SoleReferences) into the kernel:
    every field `_kernel.reference_fields()` lists, the ones its class lacks as empty."""
    kernel.set_references(refs)


class NativeOutput(ControlOutput):
    """A native tick's ControlOutput: τ, q̈ and F are arrays of its own; the hierarchy solution
    and the task errors are built from the kernel's report of that tick (`_kernel.TickOutcome`,
    a copy) when first read: telemetry reads them at 100 Hz, the loop ticks at 1 kHz."""

    def __init__(self, tau: np.ndarray, x: np.ndarray, nv: int, outcome: "_kernel.TickOutcome"):
        self.tau, self.qdd, self.forces = tau, x[:nv], x[nv:]
        self._x, self._outcome = x, outcome
        self._solution: HierarchySolution | None = None
        self._status: SolveStatus | None = None

    @property
    def solution(self) -> HierarchySolution:  # type: ignore[override]
        if self._solution is None:
            o = self._outcome
            self._solution = HierarchySolution(
                self._x,
                o.levels,
                o.residuals,
                o.qp_solves,
                o.level_seconds,
                violations=o.violations,
                capped=o.capped,
                active_sets=o.active_sets,
            )
        return self._solution

    @property
    def task_errors(self) -> dict[str, float]:  # type: ignore[override]
        errors: dict[str, float] = self._outcome.task_errors
        return errors

    @property
    def fallback_levels(self) -> tuple[int, ...]:
        levels: tuple[int, ...] = self._outcome.fallback_levels
        return levels

    def solve_status(self) -> SolveStatus:
        """ok, or fallback, capped (nullspace) or violated (wbosc) with its level and reason:
        the solution is built only then. Kept: the session reads it each tick, and `lab bench`
        again (three crossings each, two of them building tuples)."""
        if self._status is None:
            o = self._outcome
            self._status = (
                self.solution.solve_status()
                if o.capped or o.fallback_levels or o.violations
                else SOLVED
            )
        return self._status

    def torques_finite(self) -> bool:
        """True: the kernel fails a tick whose τ is not finite."""
        return True


class NativeController(WholeBodyController):
    """A WholeBodyController with a `kernel` choice; `kernel_ran` says which ran last."""

    def __init__(
        self,
        robot: RobotModel,
        references: References,
        config: ControllerConfig,
        torque_limits: np.ndarray,
        serialized_model: str | None = None,
    ) -> None:
        """`serialized_model`: `robot.model.saveToString()` if made already (a robot kept for
        switches makes it once: it keeps the GIL for 0.5-2 ms)."""
        if config.kernel not in KERNELS:
            raise KeyError(f"unknown kernel {config.kernel!r} (kernels: {', '.join(KERNELS)})")
        self._native: _kernel.Kernel | None = None
        self._unsupported = ""  # why the native kernel cannot run the stack ('' when it can)
        self._kernel_inputs: list[Task] = []  # the stack's tasks with KERNEL_INPUTS
        super().__init__(robot, references, config, torque_limits)
        self.kernel_ran = "python"
        self._outcome: _kernel.TickOutcome | None = None  # the last native tick's report
        # where the last native tick's report is fetched from when first read (a server tick
        # that ended plainly: `ticked_elsewhere`), None when `_outcome` is it
        self._fetch_outcome: Callable[[], _kernel.TickOutcome] | None = None
        if _kernel is not None:
            self._native = kernel_for(self, serialized_model)
            self._native.mirror_model(robot.arrays())
            self._mirror_stack(config.stack)
            for name, task in self.tasks.items():
                self._mirror_gains(name, task.gains)
        self._synced: tuple = ()
        # the (method, formulation) last set in the kernel (empty before the first solve)
        self._native_method: tuple[str, str] = ("", "")
        self._tau, self._x = np.zeros(robot.na), np.zeros(robot.nx)  # the kernel writes these

    @property
    def _built(self) -> "_kernel.Kernel":
        """The native kernel, where it is known to be built (a native tick, a mirror call)."""
        assert self._native is not None
        return self._native

    # ----------------------------------------------------------------------------- settings
    @property
    def kernel_note(self) -> str:
        """Why the requested native kernel does not run the current stack ('' when it does)."""
        if self.config.kernel != "native":
            return ""
        if NOT_BUILT:
            return NOT_BUILT
        if self.config.method not in NATIVE_METHODS:
            return f"the native kernel has no method {self.config.method!r}"
        if self.config.solver not in NATIVE_SOLVERS:
            return (
                f"the native kernel solves its QPs with {', '.join(NATIVE_SOLVERS)} only: "
                f"solver {self.config.solver!r} runs on the Python kernel"
            )
        return self._unsupported

    @property
    def note(self) -> str:
        """Why what runs differs from what the config asks ('' when it does not): the kernel
        (`kernel_note`), and a solver or formulation the method does not use."""
        return "; ".join(n for n in (self.kernel_note, hierarchy_note(self.config)) if n)

    def set_kernel(self, kernel: str) -> None:
        """Run the next ticks on `kernel` (native or python); raises KeyError for another name."""
        if kernel not in KERNELS:
            raise KeyError(f"unknown kernel {kernel!r} (kernels: {', '.join(KERNELS)})")
        if kernel != self.config.kernel:
            self.forget_last_solution()  # the other kernel's last nullspace search is stale
        self.config.kernel = kernel

    def forget_last_solution(self) -> None:
        """As WholeBodyController.forget_last_solution, in the kernel too (it keeps its own last
        active rows and x for its nullspace searches)."""
        super().forget_last_solution()
        if self._native is not None:
            self._native.forget_last_solution()

    def set_hands(self, frames: tuple[str, ...], joints: tuple[str, ...] | None = None) -> None:
        """As WholeBodyController.set_hands, mirrored into the kernel."""
        super().set_hands(frames, joints)
        if self._native is not None:
            self._native.set_hands(list(frames), list(self.hand_joints))

    def set_stack(self, stack: Stack) -> None:
        """As WholeBodyController.set_stack, mirrored into the kernel."""
        super().set_stack(stack)
        if self._native is not None:
            self._mirror_stack(stack)

    def _mirror_stack(self, stack: Stack) -> None:
        try:
            self._built.set_stack(stack.as_lists())
            self._unsupported = ""
            tasks = [self.tasks[name] for name in stack.names() if name in self.tasks]
            self._kernel_inputs = [task for task in tasks if task.KERNEL_INPUTS]
        except KeyError as error:  # a task written in Python only: the Python kernel runs it
            self._unsupported = error.args[0]

    def set_gains(
        self,
        task: str,
        kp: float | None = None,
        kd: float | None = None,
        weight: float | None = None,
    ) -> TaskGains:
        """As WholeBodyController.set_gains, mirrored into the kernel."""
        gains = super().set_gains(task, kp, kd, weight)
        if self._native is not None:
            self._mirror_gains(task, gains)
        return gains

    def _mirror_gains(self, task: str, gains: TaskGains) -> None:
        """Copy a task's gains into the kernel; a task written in Python only (the kernel raises
        KeyError for it) runs on the Python kernel, whose stack check says so."""
        with contextlib.suppress(KeyError):
            self._built.set_gains(task, gains.kp, gains.kd, gains.weight)

    # ----------------------------------------------------------------------------- the tick
    def _runs_native(self) -> bool:
        """Whether the native kernel runs the next tick: asked for, and no `kernel_note`."""
        return self.config.kernel == "native" and not self.kernel_note

    def update(self, q: np.ndarray, v: np.ndarray) -> None:
        """Read the state (q, v) with the model update of the kernel that runs next: the native
        one fills the Python model's arrays too, so behaviours read the same pass."""
        if not self._runs_native():
            super().update(q, v)
            return
        self._built.update(q, v)
        self.robot.filled_elsewhere()

    def solve(self) -> ControlOutput:
        """Torques at the state of the last update, from the kernel the config picks; raises
        QPFailure when the hierarchy has no solution."""
        if not self._runs_native():
            self.kernel_ran = "python"
            self._catch_up_momentum()
            return super().solve()
        if self.robot.updated_by != "native":  # the kernel's own state is the Python update's
            return self._native_tick(self.robot.q, self.robot.v)
        return self._native_tick(None, None)

    def compute(self, q: np.ndarray, v: np.ndarray) -> ControlOutput:
        """Torques for state (q, v): on the native kernel the model update (which fills the
        Python model's arrays too) and the solve are one crossing; raises QPFailure when the
        hierarchy has no solution."""
        if not self._runs_native():
            self._catch_up_momentum()
            return super().compute(q, v)
        return self._native_tick(q, v)

    def _catch_up_momentum(self) -> None:
        """The momentum task's LQR schedule brought up to the blend steps the kernel made on
        its own (MomentumTask.catch_up), before Python reads or steps it."""
        if self._native is not None:
            self._task(MomentumTask).catch_up(self._native)

    def momentum_gain(self) -> np.ndarray | None:
        """As WholeBodyController.momentum_gain, the kernel's own blend steps caught up."""
        self._catch_up_momentum()
        return super().momentum_gain()

    def momentum_gain_in_use(self) -> dict | None:
        """As WholeBodyController.momentum_gain_in_use, the kernel's own blend steps caught up."""
        self._catch_up_momentum()
        return super().momentum_gain_in_use()

    def _native_tick(self, q: np.ndarray | None, v: np.ndarray | None) -> "NativeOutput":
        """One crossing: references in, the model update at (q, v) if given, the solve, τ and x
        into the preallocated arrays; the rest stays in the kernel's outcome until read."""
        native = self._built
        self.prepare_native_tick()
        outcome = native.tick_into(self.references, self._tau, self._x, q, v)
        if q is not None:
            self.robot.filled_elsewhere()
        return self.finish_native_tick(outcome, self._tau, self._x)

    @property
    def server_tick_note(self) -> str:
        """Why the server's native tick (lab/world/native_tick.py: plant, behaviour and
        controller in one crossing) cannot run this controller ('' when it can): the native
        kernel does not run the stack."""
        if self._native is None or not self._runs_native():
            return self.kernel_note or f"kernel {self.config.kernel!r} was asked for"
        return ""

    @property
    def reports_to_tasks(self) -> bool:
        """Whether a task of the stack takes values back from each native tick (`from_kernel`:
        a KERNEL_INPUTS task, Kim eq. 12's feedback)."""
        return bool(self._kernel_inputs)

    @property
    def native_kernel(self) -> "_kernel.Kernel | None":
        """The native kernel this controller mirrors into (None when it is not built)."""
        return self._native

    def prepare_native_tick(self) -> None:
        """Before a native tick's crossing: mirror what changed since the last (the method:
        `native_settings`; the limits and the tasks' inputs: `sync_native_tick`) and mark the
        tick native."""
        self.ran = self.native_settings()
        self.sync_native_tick()

    def native_settings(self) -> Ran:
        """Mirror the method and formulation into the kernel when they changed; what a native
        tick computes under the config (a session's tick plan asks once per config)."""
        method = (self.config.method, self.config.formulation)
        if self._native_method != method:  # Python strs: no crossing to compare
            self._built.set_method(method[0])  # a native tick runs only where it is built
            self._built.set_formulation(method[1])
            self._native_method = method
        return self.ran_on("native")

    def sync_native_tick(self) -> None:
        """What every native tick mirrors first: the limits given since the last tick (a
        scenario's overrides replace the arrays or change the numbers in place) and what the
        stack's tasks hold in Python (`to_kernel`)."""
        self._sync_limits()
        for task in self._kernel_inputs:
            task.to_kernel(self._built, self.robot, self.references)

    def finish_native_tick(
        self, outcome: "_kernel.TickOutcome", tau: np.ndarray, x: np.ndarray
    ) -> "NativeOutput":
        """After a native tick's crossing, its report: the output (copies of `tau` and `x`,
        which the kernel wrote); raises QPFailure when it failed, warns when nullspace's search
        stopped at its cap."""
        self.kernel_ran = "native"
        self._outcome, self._fetch_outcome = outcome, None
        for task in self._kernel_inputs:  # what telemetry reads of them (Kim eq. 12's feedback)
            task.from_kernel(outcome)
        if not outcome.ok:
            raise QPFailure(f"native {self.config.method}: {outcome.message}")
        if outcome.capped:  # as nullspace.py's search warns, for the session to show
            warnings.warn(outcome.message, ActiveSetCapWarning, stacklevel=3)
        return NativeOutput(tau.copy(), x.copy(), self.robot.nv, outcome)

    def ticked_elsewhere(self, fetch: "Callable[[], _kernel.TickOutcome]") -> None:
        """A server tick's crossing (lab/world/native_tick.py) ran this controller on the kernel
        and its status was ok (no report to raise or warn about, no KERNEL_INPUTS task to take
        values back): its report is fetched with `fetch` when first read (`native_output`,
        `task_errors`), before the next tick."""
        self.kernel_ran = "native"
        self._outcome, self._fetch_outcome = None, fetch

    def _last_outcome(self) -> "_kernel.TickOutcome | None":
        """The last native tick's report (fetched now if a server tick left it in the kernel)."""
        if self._fetch_outcome is not None:
            self._outcome, self._fetch_outcome = self._fetch_outcome(), None
        return self._outcome

    def native_output(self, tau: np.ndarray, x: np.ndarray) -> "NativeOutput":
        """The output of the last native tick that `ticked_elsewhere` reported, from the `tau`
        and `x` it wrote (copied)."""
        outcome = self._last_outcome()
        assert outcome is not None  # a native tick ran
        return NativeOutput(tau.copy(), x.copy(), self.robot.nv, outcome)

    def set_sensing(self, foot_forces: np.ndarray, applied_torques: np.ndarray) -> None:
        """As WholeBodyController.set_sensing, mirrored into the kernel."""
        super().set_sensing(foot_forces, applied_torques)
        if self._native is not None:
            forces = np.array(foot_forces, dtype=float)
            self._native.set_sensing(forces, np.array(applied_torques, dtype=float))

    def _sync_limits(self) -> None:
        """Mirror limits the Python constraints were given since the last tick (scenario
        overrides replace the arrays; friction and the level weight ratio are numbers)."""
        config, limits = self.config, self.config.limits
        # every tick: identities and numbers compared as they are (a tuple of them cost more)
        torque, joints, synced = self._torque_limits.torque_limits, self._joint_limits, self._synced
        if (
            synced
            and synced[0][0] is torque
            and synced[0][1] is joints.lower
            and synced[0][2] is joints.upper
            and synced[1][0] == limits.friction
            and synced[1][1] == limits.normal_min
            and synced[1][2] == limits.normal_max
            and synced[1][3] == config.level_weight_ratio
        ):
            return
        arrays = (self.torque_limits(), *self.joint_limits())
        numbers = (limits.friction, limits.normal_min, limits.normal_max, config.level_weight_ratio)
        native = self._built
        native.set_torque_limits(arrays[0])
        native.set_joint_limits(arrays[1], arrays[2])
        native.set_contact_limits(*numbers[:3])
        native.set_level_weight_ratio(numbers[3])
        self._synced = (arrays, numbers)

    @property
    def kernel_seconds(self) -> tuple[float, float, float] | None:
        """Seconds the native kernel's last tick took in each stage, measured inside it (no
        Python around them): model update, rows, hierarchy method with the torques; None when
        the last tick ran on the Python kernel."""
        return self._built.seconds if self.kernel_ran == "native" else None

    def task_errors(self) -> dict[str, float]:
        """Norm of each stack task's tracking error at the last tick, from the kernel that ran."""
        outcome = self._last_outcome() if self.kernel_ran == "native" else None
        if outcome is not None:
            errors: dict[str, float] = outcome.task_errors
            return errors
        return super().task_errors()
