"""The internal force between point feet in support, with sensor feedback (Kim 2016 §IV).

Rows over the forces of x = [q̈, F]: W_int λ = F_int,cmd with λ = −F (eq. 41) and the command of
eq. 12, F_int,cmd = F_int,ref + K_F (F_int,ref − F_int,act). K_F is the task's kp (Kim's Table I:
1.0). The sensed F_int,act comes, as `source` says, from the measured contact forces of the last
step (`contacts`: a foot force sensor) or from the joint torques through the contact-consistent
dynamics (`torques`, eq. 13: what Hume's series-elastic torque sensors give). With fewer than
two point feet in support the task has no rows. The error is F_int,ref − F_int,act (N).
"""

from typing import ClassVar

import numpy as np

from lab.controller.contact_dynamics import contact_dynamics
from lab.controller.internal_force import internal_force_map, internal_forces
from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.rows import contact_rows
from lab.controller.tasks.base import (
    KernelInputs,
    KernelReport,
    Task,
    TaskGains,
    TaskRows,
    no_task_rows,
)

SENSED_SOURCES = ("contacts", "torques")


class InternalForceTask(Task):
    """Tension between the point feet in support (N, > 0 pushing apart), tracked with the
    proportional feedback of Kim eq. 12 on the sensed internal force."""

    name = "internal_force"
    GAINS = ("kp", "weight")
    READS_SENSING: ClassVar[bool] = True  # F_int,act, Kim eq. 12's feedback
    KERNEL_INPUTS: ClassVar[bool] = True  # its reference and source, set by a command

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self.reference = 0.0  # F_int,ref (N), the same for every pair of feet
        self.source = "contacts"  # where F_int,act comes from (SENSED_SOURCES)
        self.measured_forces: np.ndarray | None = None  # on each foot (n × 3, world), last step
        self.applied_torques: np.ndarray | None = None  # τ applied over the last step (N m)
        self.sensed = np.zeros(0)  # F_int,act at the last `rows`
        self.command = np.zeros(0)  # F_int,cmd at the last `rows`
        self._kernel_setting: tuple[float, str] | None = None  # (reference, source) it holds

    def set_source(self, source: str) -> None:
        """Sense the internal force from `contacts` or `torques`; raises ValueError otherwise."""
        if source not in SENSED_SOURCES:
            raise ValueError(f"unknown source {source!r} (sources: {', '.join(SENSED_SOURCES)})")
        self.source = source

    def sense(self, foot_forces: np.ndarray, applied_torques: np.ndarray) -> None:
        """Keep the foot forces and applied torques measured over the last step (Kim eqs.
        12–13)."""
        self.measured_forces = np.array(foot_forces, dtype=float)
        self.applied_torques = np.array(applied_torques, dtype=float)

    def to_kernel(self, kernel: KernelInputs, robot: RobotModel, refs: References) -> None:
        """Hand the kernel the reference and the sensed source when they change (the
        `internal_force` command sets them here); eq. 12's feedback runs in the kernel on the
        sensing the controller hands it."""
        setting = (self.reference, self.source)
        if setting != self._kernel_setting:
            kernel.set_internal_force(*setting)
            self._kernel_setting = setting

    def from_kernel(self, report: KernelReport) -> None:
        """Take the native tick's F_int,act and F_int,cmd (telemetry shows them)."""
        self.sensed, self.command = report.internal_force_sensed, report.internal_force_command

    def feedback(
        self, robot: RobotModel, refs: References
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(feet, F_int,cmd, error) this tick: the point feet in support, the command of eq. 12
        for each pair of them and the error F_int,ref − F_int,act (empty before the first sensed
        step); no command with fewer than two feet. Sets `sensed` and `command`. The rows' right
        side, which the native kernel takes from here."""
        feet = np.flatnonzero(
            refs.contact_active & np.array([c.kind == "point" for c in robot.contacts])
        )
        if len(feet) < 2:
            self.sensed, self.command = np.zeros(0), np.zeros(0)
            return feet, self.command, np.zeros(0)
        positions = robot.contact_positions[feet]
        reference = np.full(len(feet) * (len(feet) - 1) // 2, self.reference)  # one per pair
        self.sensed = self._sensed(robot, refs, feet, positions)
        if self.sensed.size:
            error = reference - self.sensed
            self.command = reference + self.gains.kp * error  # eq. 12
        else:
            error, self.command = np.zeros(0), reference
        return feet, self.command, error

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        feet, command, error = self.feedback(robot, refs)
        if len(feet) < 2:
            return no_task_rows(robot.nx)
        W = internal_force_map(robot.contact_positions[feet])
        A = np.zeros((len(W), robot.nx))
        columns = robot.nv + np.concatenate(
            [np.arange(3) + robot.force_slices[i].start for i in feet]
        )
        A[:, columns] = -W  # W_int λ with λ = −F
        return TaskRows(A, command.copy(), error)

    def _sensed(
        self, robot: RobotModel, refs: References, feet: np.ndarray, positions: np.ndarray
    ) -> np.ndarray:
        """F_int,act from the chosen source (empty before the first sensed step)."""
        if self.source == "contacts":
            if self.measured_forces is None:
                return np.zeros(0)
            return internal_forces(positions, self.measured_forces[feet])
        if self.applied_torques is None:
            return np.zeros(0)
        support = contact_rows(robot, refs.contact_active)
        dynamics = contact_dynamics(robot.M, robot.h, robot.Jc[support], robot.Jc_dot_v[support])
        forces = dynamics.force_of_torque @ self.applied_torques + dynamics.force_free  # eq. 13
        active = np.flatnonzero(refs.contact_active)
        per_foot = dict(
            zip(active, np.split(forces, np.cumsum(robot.force_dims[active])[:-1]), strict=True)
        )
        return internal_forces(positions, np.array([per_foot[i][:3] for i in feet]))
