"""Behaviours own the references and the contact schedule; the controller owns the math.

A behaviour is built from the robot model and its standing posture, exposes the `References` the
tasks track, and updates them once per tick from the time, the robot's current state (after
`RobotModel.update`), the velocity command [vx, vy, yaw_rate] (heading frame) and which feet
touch the ground (measured by the plant: the haptic signal of a blind robot).
"""

from collections.abc import Callable

import numpy as np

from lab.controller.behaviours.balance import Balance
from lab.controller.behaviours.base import Behaviour
from lab.controller.behaviours.biped_step import BIPED_BEHAVIOURS
from lab.controller.behaviours.com_ellipse import ComEllipse
from lab.controller.behaviours.hutter import HUTTER_BEHAVIOURS
from lab.controller.behaviours.squat import CopSquat, Squat
from lab.controller.behaviours.walking import WALKING_BEHAVIOURS
from lab.controller.model import RobotModel

BehaviourFactory = Callable[[RobotModel, np.ndarray], Behaviour]

BEHAVIOURS: dict[str, BehaviourFactory] = {
    Balance.name: Balance,
    **HUTTER_BEHAVIOURS,
    **WALKING_BEHAVIOURS,
    Squat.name: Squat,
    CopSquat.name: CopSquat,
    **BIPED_BEHAVIOURS,
    ComEllipse.name: ComEllipse,
}

__all__ = ["BEHAVIOURS", "Balance", "Behaviour", "BehaviourFactory"]
