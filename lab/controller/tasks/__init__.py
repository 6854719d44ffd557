"""Tasks: equality rows `A x = b` over x = [q̈, F], one module per kind, and their registry.

`TASK_TYPES` lists every task a stack can name, in the order the UI shows them. Each task is
built with its `TaskGains` and returns `TaskRows` (A, b and its tracking error) every tick.
"""

from lab.controller.tasks.base import ALL_GAINS, Task, TaskGains, TaskRows
from lab.controller.tasks.com import ComAcrossFeetTask, ComAlongFeetTask, ComTask, ComXYTask
from lab.controller.tasks.contact import ContactTask
from lab.controller.tasks.feet import SwingFeetTask
from lab.controller.tasks.hands import HandsTask
from lab.controller.tasks.internal_force import InternalForceTask
from lab.controller.tasks.momentum import MomentumTask
from lab.controller.tasks.objectives import (
    ForceInterpolationTask,
    ForceNormalTask,
    ForceTask,
    InternalWrenchTask,
    SoleForceTask,
    TorqueTask,
)
from lab.controller.tasks.posture import MovingPostureTask, PostureTask, UpperBodyTask
from lab.controller.tasks.sole import SwingLegTask, SwingSoleTask
from lab.controller.tasks.trunk import (
    BaseHeightTask,
    BaseOrientationTask,
    PlanarVelocityTask,
    RollPitchTask,
    YawRateTask,
)

TASK_TYPES: dict[str, type[Task]] = {
    task.name: task
    for task in (
        ContactTask,
        BaseOrientationTask,
        ComTask,
        BaseHeightTask,
        PostureTask,
        ForceTask,
        MomentumTask,
        TorqueTask,
        ForceNormalTask,
        ForceInterpolationTask,
        RollPitchTask,
        YawRateTask,
        PlanarVelocityTask,
        SwingFeetTask,
        ComXYTask,
        MovingPostureTask,
        InternalForceTask,
        SwingSoleTask,
        SwingLegTask,
        InternalWrenchTask,
        ComAlongFeetTask,
        ComAcrossFeetTask,
        HandsTask,
        UpperBodyTask,
        SoleForceTask,
    )
}

__all__ = ["ALL_GAINS", "TASK_TYPES", "Task", "TaskGains", "TaskRows"]
