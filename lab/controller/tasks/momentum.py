"""The centroidal momentum task of Herzog 2016 (eqs. 19–24), usable at any level.

Rows over x = [q̈, F]: A_G q̈ = ḣ_des − Ȧ_G v (eq. 20, pinocchio's centroidal map and its drift),
with ḣ_des = −K_h s + ḣ_ref from lab/controller/momentum.py: diagonal PD gains (eq. 22) or the
LQR design of eqs. 23–26, chosen by `mode`. The reference momentum is [m ċ_ref; 0] and its
rate ḣ_ref = [m c̈_ref; 0] is fed forward (the squat's known acceleration). The error is s,
the CoG error and the momentum errors [Δc; Δh_lin; Δh_ang]
(m, kg m/s, kg m²/s; world axes, about the CoM).
"""

from collections.abc import Callable
from typing import ClassVar

import numpy as np

from lab.controller.model import RobotModel
from lab.controller.momentum import (
    ARM_TOLERANCE,
    LQR_COSTS,
    MOMENTUM_MODES,
    GainSchedule,
    LqrProblem,
    contact_arms,
    lqr_problem,
    pd_gain,
)
from lab.controller.references import References
from lab.controller.tasks.base import KernelInputs, KernelSchedule, Task, TaskGains, TaskRows


class MomentumTask(Task):
    """Centroidal momentum rate ḣ = −K_h s (Herzog eqs. 22 and 24), K_h from PD or LQR (kp, kd
    are read in `pd` mode only)."""

    name = "momentum"
    KERNEL_INPUTS: ClassVar[bool] = True  # K_h, designed in Python

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self.mode = "lqr"
        self.cost = LQR_COSTS[self.mode]
        self.schedule = GainSchedule()
        self._kernel_pd: tuple[float, float] | None = None  # (kp, kd) of the PD K_h it holds
        self._kernel_lqr: np.ndarray | None = None  # the scheduled K_h the kernel holds
        self._scheduled = False  # whether the kernel asks `_schedule_tick` (LQR)
        self._version = -1  # the schedule's version when the kernel was last handed K_h
        # the model and references the kernel's next tick reads (set before each crossing)
        self._kernel_reads: tuple[RobotModel, References] | None = None

    def set_mode(self, mode: str) -> None:
        """`pd` (eq. 22), or `lqr` / `lqr_talos` (eqs. 23–26 with the printed cost or the one
        retuned for Talos); raises ValueError naming the modes."""
        if mode not in MOMENTUM_MODES:
            raise ValueError(f"unknown momentum mode {mode!r} (modes: {', '.join(MOMENTUM_MODES)})")
        if mode != self.mode:
            self.mode = mode
            self.cost = LQR_COSTS.get(mode, self.cost)
            self.schedule.clear()

    def gain(self, robot: RobotModel, refs: References) -> np.ndarray:
        """This tick's K_h (6 × 9): PD from the task's gains, LQR per contact configuration and
        pose (GainSchedule)."""
        if self.mode == "pd":
            return pd_gain(robot.mass, self.gains.kp, self.gains.kd)
        return self._scheduled_gain(robot, refs)

    def _scheduled_gain(self, robot: RobotModel, refs: References) -> np.ndarray:
        active = refs.contact_active
        return self.schedule.gain(
            active.tobytes(), contact_arms(robot, active), self._problem(robot, active)
        )

    def catch_up(self, kernel: KernelInputs) -> None:
        """Bring the schedule's blend up to the steps `kernel` made on its own since it last
        asked (`GainSchedule.skip`), before the schedule is read or stepped outside its ticks
        (the caller passes the kernel: held here, it and its schedule would hold each other)."""
        if self._scheduled:
            self.schedule.skip(kernel.take_momentum_blend_steps())
            self._kernel_lqr = self.schedule.current  # the same K_h the kernel holds

    def target_gain(self, robot: RobotModel, refs: References) -> np.ndarray:
        """K_h (6 × 9) of the current contact configuration and pose, without a tick: what
        `gain` gives once an interpolation is over (the UI shows it)."""
        if self.mode == "pd":
            return pd_gain(robot.mass, self.gains.kp, self.gains.kd)
        active = refs.contact_active
        return self.schedule.target(
            active.tobytes(), contact_arms(robot, active), self._problem(robot, active)
        )

    def to_kernel(self, kernel: KernelInputs, robot: RobotModel, refs: References) -> None:
        """Before a native crossing: under `pd` hand the kernel K_h when the gains change; under
        LQR let the kernel ask `_schedule_tick` inside its tick, after its model update and the
        behaviour, on the ticks where no settled K_h holds (another contact configuration, an
        arm moved more than ARM_TOLERANCE: checked in the kernel), and drop the one it holds
        when the schedule changed since it was handed (a mode, a design from outside a tick)."""
        if self.mode == "pd":
            if self._scheduled:
                kernel.set_momentum_schedule(None, ARM_TOLERANCE)
                self._scheduled = False
            pd = (self.gains.kp, self.gains.kd)
            if pd != self._kernel_pd:
                kernel.set_momentum_gain(self.gain(robot, refs))
                self._kernel_pd, self._kernel_lqr = pd, None
            return
        self._kernel_reads = (robot, refs)
        if not self._scheduled:
            kernel.set_momentum_schedule(self._schedule_tick, ARM_TOLERANCE)
            self._scheduled, self._kernel_pd = True, None
        elif (
            self._kernel_lqr is not self.schedule.current or self._version != self.schedule.version
        ):
            kernel.release_momentum_gain()

    def _schedule_tick(self, blended: int) -> KernelSchedule:
        """The kernel's ask, inside its tick, after `blended` blend steps it made on its own:
        this tick's K_h (GainSchedule.gain: a design, a switch, an interpolation step), and the
        contact flags and arms to hold its target at while it stays, with the blend the kernel
        steps meanwhile (None, None, None while it does not: the kernel asks again next
        tick)."""
        assert self._kernel_reads is not None  # to_kernel ran before the crossing
        robot, refs = self._kernel_reads
        self.schedule.skip(blended)
        gain = self._scheduled_gain(robot, refs)
        self._kernel_lqr, self._version = gain, self.schedule.version
        active = refs.contact_active
        arms = self.schedule.held_arms(active.tobytes())
        if arms is None:
            return gain, None, None, None
        return gain, active.copy(), arms, self.schedule.blend()

    def _problem(self, robot: RobotModel, active: np.ndarray) -> Callable[[], LqrProblem]:
        return lambda: lqr_problem(robot, active, self.cost)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        h = robot.centroidal_momentum()
        s = np.concatenate((robot.com - refs.com, h[:3] - robot.mass * refs.com_velocity, h[3:]))
        A, view = self._matrix(robot, 6)
        A[:, : robot.nv] = robot.centroidal_map
        # ḣ_des = −K_h s + ḣ_ref (eq. 22's feed-forward): ḣ_ref = [m c̈_ref; 0]
        b = -self.gain(robot, refs) @ s - robot.centroidal_drift()
        b[:3] += robot.mass * refs.com_acceleration
        return TaskRows(view, b, s)
