"""WholeBodyController: one tick from state (q, v) to joint torques.

state → RobotModel.update → tasks and constraints become rows, level by level as the stack says
→ hierarchy method → x = [q̈, F] → τ = M_a q̈ + h_a − J_aᵀ F (Herzog eq. 14).

Over 400 lines: most of it is one class, WholeBodyController, whose methods share its tasks,
constraints, stack and last solution; its configuration and output types sit beside it.
"""

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import TypeVar

import numpy as np

from lab.controller.constraints import (
    Constraint,
    ContactLimits,
    CopConstraint,
    FrictionConstraint,
    InnerCopConstraint,
    JointLimitConstraint,
    SoleTorsionConstraint,
    TorqueLimitConstraint,
)
from lab.controller.hierarchy import (
    FORMULATION_METHODS,
    METHODS,
    NO_SOLVER,
    QP_METHODS,
    STACK_CHECKS,
    HierarchyProblem,
    HierarchySolution,
    Level,
)
from lab.controller.hierarchy.formulations import FORMULATIONS
from lab.controller.hierarchy.problem import DynamicsTerms
from lab.controller.hierarchy.solution import SolveStatus
from lab.controller.model import BASE_DOF, RobotModel
from lab.controller.momentum import GainFuture, LqrProblem
from lab.controller.qp import SOLVERS
from lab.controller.references import References
from lab.controller.rows import PerContactSet, no_rows, read_only
from lab.controller.stack import Stack
from lab.controller.tasks import TASK_TYPES, Task, TaskGains
from lab.controller.tasks.hands import HandsTask
from lab.controller.tasks.internal_force import InternalForceTask
from lab.controller.tasks.momentum import MomentumTask

_T = TypeVar("_T", bound=Task)


@dataclass
class ControllerConfig:
    """Everything that selects and tunes the controller; the session edits it live."""

    stack: Stack
    gains: dict[str, TaskGains] = field(default_factory=dict)
    method: str = "cascade"  # hierarchy method, a key of METHODS
    solver: str = "daqp"
    limits: ContactLimits = field(default_factory=ContactLimits)
    level_weight_ratio: float = 1e3  # `weighted` only: each level with tasks weighs this much less
    formulation: str = "qdd_force"  # `nullspace` only: optimization vector (Hutter 2014 §4)
    # Which kernel computes the tick: `native` (lab._kernel, when built; see native.py) or
    # `python` (this module). A plain WholeBodyController always runs `python`.
    kernel: str = "native"


@dataclass(frozen=True)
class Ran:
    """What computed a tick: the kernel (`native` or `python`), the hierarchy method, the QP
    solver (`none` for a method that solves no QP) and the formulation (the decision variable:
    `qdd_force`, x = [q̈, F], for every method but nullspace, whose formulation is chosen)."""

    kernel: str
    method: str
    solver: str
    formulation: str

    def report(self) -> dict[str, str]:
        """JSON-ready: telemetry's and the scenario report's `ran`."""
        return {
            "kernel": self.kernel,
            "method": self.method,
            "solver": self.solver,
            "formulation": self.formulation,
        }


def ran_by(kernel: str, config: "ControllerConfig") -> Ran:
    """What a tick of `kernel` computes under `config`: the method's own solver and formulation."""
    method = config.method
    solver = config.solver if method in QP_METHODS else NO_SOLVER
    formulation = config.formulation if method in FORMULATION_METHODS else "qdd_force"
    return Ran(kernel, method, solver, formulation)


def hierarchy_note(config: "ControllerConfig") -> str:
    """Why the solver or formulation `config` asks for does not run under its method ('' when
    they do): nullspace and wbosc solve no QP; only nullspace has formulations."""
    notes = []
    if config.method not in QP_METHODS:
        notes.append(f"{config.method} solves no QP (solver {config.solver!r} unused)")
    if config.method not in FORMULATION_METHODS and config.formulation != "qdd_force":
        notes.append(
            f"formulation {config.formulation!r} is nullspace's: {config.method} computes [q̈, F]"
        )
    return "; ".join(notes)


@dataclass
class ControlOutput:
    """One tick's result: joint torques τ (N m, pinocchio joint order), x = [q̈, F] split into
    q̈ (the generalized accelerations, base part in the base frame) and F (contact forces in the
    layout of RobotModel), how the hierarchy found it, and the norm of each stack task's
    tracking error (task units)."""

    tau: np.ndarray
    qdd: np.ndarray
    forces: np.ndarray
    solution: HierarchySolution
    task_errors: dict[str, float]

    @property
    def fallback_levels(self) -> tuple[int, ...]:
        """The solution's fallback levels (HierarchySolution.fallback_levels)."""
        return self.solution.fallback_levels

    def solve_status(self) -> SolveStatus:
        """How the hierarchy found x: ok, fallback, capped or violated, with level and reason."""
        return self.solution.solve_status()

    def torques_finite(self) -> bool:
        """Whether every torque is finite (NaN and inf propagate into the dot product)."""
        return math.isfinite(self.tau.dot(self.tau))


class WholeBodyController:
    """The whole-body controller of one robot: the tasks of TASK_TYPES and the constraints,
    arranged by the stack into levels, solved by the configured hierarchy method into
    x = [q̈, F] and joint torques (module docstring). It reads the shared `robot` model, which
    the caller updates, and the behaviour's `references`."""

    def __init__(
        self,
        robot: RobotModel,
        references: References,
        config: ControllerConfig,
        torque_limits: np.ndarray,
    ) -> None:
        self.robot = robot
        self.references = references
        self.config = config
        self.tasks: dict[str, Task] = {
            name: task_type(config.gains.get(name, TaskGains()))
            for name, task_type in TASK_TYPES.items()
        }
        model = robot.model
        self._torque_limits = TorqueLimitConstraint(torque_limits)
        self._joint_limits = JointLimitConstraint(
            model.lowerPositionLimit[7:], model.upperPositionLimit[7:]
        )
        self.constraints: dict[str, Constraint] = {
            "friction": FrictionConstraint(config.limits),
            "torque_limits": self._torque_limits,
            "joint_limits": self._joint_limits,
        }
        if any(c.kind == "flat" for c in robot.contacts):
            self.constraints["cop"] = CopConstraint()
            self.constraints["cop_inner"] = InnerCopConstraint()
            self.constraints["sole_torsion"] = SoleTorsionConstraint(config.limits)
        self._support = PerContactSet(_support_mask)
        self._errors: dict[str, np.ndarray] = {}  # each task's tracking error at the last tick
        self._sensing_stack: Stack | None = None  # the stack `reads_sensing` last answered for
        self._reads_sensing = False
        # nullspace: where the last tick's active-set searches stopped, this tick's start
        self._active_sets: tuple[list[np.ndarray], ...] = ()
        self._last_x: np.ndarray | None = None
        self._ran: dict[tuple, Ran] = {}  # by (kernel, method, solver, formulation): one each
        self.ran = ran_by("python", config)  # what computed the last tick
        self.set_stack(config.stack)
        self.set_hierarchy(config.method, config.solver, config.formulation)

    @property
    def known_names(self) -> tuple[str, ...]:
        """Every task and constraint name a stack may use."""
        return (*self.tasks, *self.constraints)

    def set_stack(self, stack: Stack) -> None:
        """Use a new stack from the next tick on; raises StackError (or the hierarchy method's
        ValueError for a task it cannot realize) and keeps the old one."""
        stack.validate(self.known_names)
        if self.config.method in STACK_CHECKS:
            STACK_CHECKS[self.config.method](stack.names())
        self.config.stack = stack
        self.forget_last_solution()  # its active rows are rows of the old stack
        # Each level's tasks and constraints, looked up here once instead of by name every tick.
        self._levels = [
            (
                [self.tasks[name] for name in names if name in self.tasks],
                [self.constraints[name] for name in names if name in self.constraints],
            )
            for names in stack.levels
        ]

    def set_hands(self, frames: tuple[str, ...], joints: tuple[str, ...] | None = None) -> None:
        """The frames the `hands` task moves, one hand each, in the order of the references' hand
        rows, and the joints each may use ("all" or "arm", tasks/hands.py; None: all); raises
        ValueError naming a frame the model lacks or a bad option, and changes nothing then."""
        self._task(HandsTask).set_frames(
            self.robot, tuple(frames), None if joints is None else tuple(joints)
        )

    @property
    def hands(self) -> tuple[str, ...]:
        """The frames the `hands` task moves (`set_hands`)."""
        return self._task(HandsTask).frames

    @property
    def hand_joints(self) -> tuple[str, ...]:
        """Each hand's joints option, "all" or "arm" (`set_hands`)."""
        return self._task(HandsTask).joints

    def _task(self, kind: type[_T]) -> _T:
        """The controller's task of class `kind` (one of each, TASK_TYPES), typed as it."""
        task = self.tasks[kind.name]
        assert isinstance(task, kind)
        return task

    def set_gains(
        self,
        task: str,
        kp: float | None = None,
        kd: float | None = None,
        weight: float | None = None,
    ) -> TaskGains:
        """Change the given gains of `task` (the others keep theirs); returns the new gains;
        raises KeyError naming the tasks for an unknown name."""
        if task not in self.tasks:
            raise KeyError(f"unknown task {task!r} (tasks: {', '.join(self.tasks)})")
        changes = {"kp": kp, "kd": kd, "weight": weight}
        gains = replace(
            self.tasks[task].gains, **{k: v for k, v in changes.items() if v is not None}
        )
        self.tasks[task].gains = gains
        return gains

    def set_hierarchy(
        self, method: str, solver: str | None = None, formulation: str | None = None
    ) -> None:
        """Use hierarchy `method` (with `solver` and, for nullspace, `formulation`; None keeps
        the current one) from the next tick on; raises KeyError naming the choices for an
        unknown name, ValueError when the method cannot realize a task of the current stack
        (wbosc), and changes nothing then."""
        solver = solver or self.config.solver
        formulation = formulation or self.config.formulation
        if method not in METHODS:
            raise KeyError(f"unknown hierarchy method {method!r} (methods: {', '.join(METHODS)})")
        if solver not in SOLVERS:
            raise KeyError(f"unknown solver {solver!r} (solvers: {', '.join(SOLVERS)})")
        if formulation not in FORMULATIONS:
            raise KeyError(
                f"unknown formulation {formulation!r} (formulations: {', '.join(FORMULATIONS)})"
            )
        if method in STACK_CHECKS:
            STACK_CHECKS[method](self.config.stack.names())
        if (method, formulation) != (self.config.method, self.config.formulation):
            self.forget_last_solution()  # another method's, or another formulation's levels
        self.config.method, self.config.solver = method, solver
        self.config.formulation = formulation

    def forget_last_solution(self) -> None:
        """Start the next `nullspace` search cold: the last tick's active rows and x, its start
        otherwise, belong to a state, stack or method that is gone (a reset, a new stack, method
        or formulation). From a stale start the search still ends at the optimum, but it may take
        up to MAX_PROJECTIONS hierarchy solves to get there, or stop at the cap short of it."""
        self._active_sets, self._last_x = (), None

    def update(self, q: np.ndarray, v: np.ndarray) -> None:
        """Read the state (q, v): the model update the next `solve` works at."""
        self.robot.update(q, v)

    def build_problem(self) -> HierarchyProblem:
        """Rows of the current stack at the state of the last RobotModel.update."""
        robot, refs = self.robot, self.references
        base = slice(0, BASE_DOF)
        # Newton–Euler rows (Herzog eq. 13): M_u q̈ − J_uᵀ F = −h_u.
        dynamics_A = np.concatenate((robot.M[base], -robot.Jc[:, base].T), axis=1)
        levels = []
        errors: dict[str, np.ndarray] = {}
        weight = 1.0  # of the next level with tasks; inequality-only levels take no weight
        for tasks, constraints in self._levels:
            A_rows, b_rows, C_rows, d_rows, labels = [], [], [], [], []
            for task in tasks:
                A, b, error = task.rows(robot, refs)
                if error.size:
                    errors[task.name] = error
                if task.gains.weight != 1.0:
                    scale = np.sqrt(task.gains.weight)
                    A, b = scale * A, scale * b
                A_rows.append(A)
                b_rows.append(b)
            for constraint in constraints:
                C, d = constraint.rows(robot, refs)
                C_rows.append(C)
                d_rows.append(d)
                labels.append((constraint.name, len(d)))
            levels.append(
                Level(
                    *_stacked(A_rows, b_rows, robot.nx),
                    *_stacked(C_rows, d_rows, robot.nx),
                    weight=weight,
                    constraint_rows=tuple(labels),
                )
            )
            if A_rows:
                weight /= self.config.level_weight_ratio
        self._errors = errors
        support = self._support.get(robot, refs.contact_active)
        terms = DynamicsTerms(
            robot.M, robot.h, robot.Jc, support, robot.Jc_dot_v, _transition_weights(robot, refs)
        )
        return HierarchyProblem(dynamics_A, -robot.h[base], levels, terms, self.config.formulation)

    def compute(self, q: np.ndarray, v: np.ndarray) -> ControlOutput:
        """Torques for state (q, v); raises QPFailure when the hierarchy has no solution."""
        self.robot.update(q, v)
        return self.solve()

    def solve(self) -> ControlOutput:
        """Torques at the state of the last RobotModel.update (a behaviour may update the
        references in between)."""
        problem = self.build_problem()
        problem.active_start, problem.x_start = self._active_sets, self._last_x
        self.ran = self.ran_on("python")
        solution = METHODS[self.config.method](problem, self.config.solver)
        self._active_sets, self._last_x = solution.active_sets, solution.x
        x, nv = solution.x, self.robot.nv
        return ControlOutput(
            self.robot.joint_torques(x), x[:nv], x[nv:], solution, self.task_errors()
        )

    def ran_on(self, kernel: str) -> Ran:
        """What a tick of `kernel` computes under the current config (one Ran per combination:
        the tick allocates none)."""
        config = self.config
        key = (kernel, config.method, config.solver, config.formulation)
        ran = self._ran.get(key)
        if ran is None:
            ran = self._ran[key] = ran_by(kernel, config)
        return ran

    def task_errors(self) -> dict[str, float]:
        """Norm of each task's tracking error at the last `build_problem` (tasks in the stack
        only)."""
        in_stack = set(self.config.stack.names())
        return {
            name: math.hypot(*self._errors[name])
            for name in self.tasks
            if name in in_stack and name in self._errors
        }

    def torque_limits(self) -> np.ndarray:
        """τ_max of each actuated joint (N m, pinocchio joint order) that `torque_limits` uses."""
        return self._torque_limits.torque_limits

    def set_torque_limits(self, limits: np.ndarray) -> None:
        """Use new torque bounds τ_max (N m, one per actuated joint) from the next tick on;
        raises ValueError for a wrong size and changes nothing then."""
        limits = np.array(limits, dtype=float)  # a new array: the kernel mirror sees the change
        if limits.shape != (self.robot.na,):
            raise ValueError(f"torque limits need {self.robot.na} values, got {limits.shape}")
        self._torque_limits.torque_limits = limits

    def joint_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper position limits of each actuated joint (rad, m for prismatic)."""
        return self._joint_limits.lower, self._joint_limits.upper

    def set_joint_limits(self, lower: np.ndarray, upper: np.ndarray) -> None:
        """Use new joint position limits from the next tick on; raises ValueError for a wrong
        size and changes nothing then."""
        lower, upper = np.array(lower, dtype=float), np.array(upper, dtype=float)
        if lower.shape != (self.robot.na,) or upper.shape != (self.robot.na,):
            raise ValueError(f"joint limits need {self.robot.na} values each")
        self._joint_limits.lower, self._joint_limits.upper = lower, upper

    @property
    def internal_force(self) -> InternalForceTask:
        """The internal-force task (Kim 2016 eq. 12): its reference, sensed source and the
        values of the last tick."""
        return self._task(InternalForceTask)

    @property
    def reads_sensing(self) -> bool:
        """Whether a task of the stack reads what `set_sensing` hands over (the internal force's
        feedback): the session measures the foot forces only then."""
        stack = self.config.stack  # frozen: the answer holds until the stack is replaced
        if stack is not self._sensing_stack:
            self._sensing_stack = stack
            tasks = (self.tasks[name] for name in stack.names() if name in self.tasks)
            self._reads_sensing = any(task.READS_SENSING for task in tasks)
        return self._reads_sensing

    def set_sensing(self, foot_forces: np.ndarray, applied_torques: np.ndarray) -> None:
        """What the sensors measured over the last step: the force of the terrain on each foot
        (n_contacts × 3, N, world) and the joint torques applied (N m), for the feedback of the
        internal force (Kim eqs. 12–13): each task that reads the sensors keeps it."""
        for task in self.tasks.values():
            if task.READS_SENSING:
                task.sense(foot_forces, applied_torques)

    def posture_gains(self) -> TaskGains:
        """The posture task's gains (the session's fallback PD uses them)."""
        return self.tasks["posture"].gains

    def momentum_mode(self) -> str:
        """The momentum task's feedback law: `pd` (Herzog eq. 22) or `lqr` (eqs. 23–26)."""
        return self._task(MomentumTask).mode

    def momentum_gain(self) -> np.ndarray | None:
        """K_h (6 × 9) the momentum task applies at the current contact configuration (Herzog eq.
        22 or 24), None while the task is not in the stack."""
        if MomentumTask.name not in self.config.stack.names():
            return None
        return self._task(MomentumTask).target_gain(self.robot, self.references)

    def set_momentum_designer(self, submit: Callable[[LqrProblem], GainFuture] | None) -> None:
        """Design the momentum task's LQR gains through `submit` (off the caller's thread: it
        returns a future) or, with None, at once (GainSchedule)."""
        self._task(MomentumTask).schedule.submit = submit

    def momentum_gain_in_use(self) -> dict | None:
        """Which LQR K_h the momentum task applies (GainSchedule.in_use); None under `pd` or
        while the task is not in the stack."""
        task = self._task(MomentumTask)
        if task.mode == "pd" or task.name not in self.config.stack.names():
            return None
        return task.schedule.in_use()

    def set_momentum_mode(self, mode: str) -> None:
        """Switch the momentum task's feedback law; raises ValueError naming the modes."""
        self._task(MomentumTask).set_mode(mode)

    def gains(self) -> Mapping[str, TaskGains]:
        """Each task's gains, by task name."""
        return {name: task.gains for name, task in self.tasks.items()}

    def gains_used(self) -> Mapping[str, tuple[str, ...]]:
        """Which of kp, kd and weight each task reads, by task name."""
        return {name: task.GAINS for name, task in self.tasks.items()}


def _stacked(
    rows: list[np.ndarray], rhs: list[np.ndarray], nx: int
) -> tuple[np.ndarray, np.ndarray]:
    if not rows:
        return no_rows(nx)
    if len(rows) == 1:
        return rows[0], rhs[0]
    return np.concatenate(rows), np.concatenate(rhs)


def _transition_weights(robot: RobotModel, refs: References) -> np.ndarray | None:
    """The load weight w of each row of F whose contact is being loaded or unloaded (NaN
    elsewhere), from a walking behaviour's references; None when they carry none."""
    walk = refs.walking
    if walk is None or len(walk.force_weight) != len(robot.contacts):
        return None
    return np.repeat(walk.force_weight, robot.force_dims)


def _support_mask(robot: RobotModel, active: np.ndarray) -> np.ndarray:
    """Which rows of F belong to contacts in support (one flag per force component)."""
    return read_only(np.repeat(active, robot.force_dims))
