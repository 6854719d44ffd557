"""The Behaviour protocol, and the defaults of a behaviour that takes no options."""

from typing import Protocol

import numpy as np

from lab.controller.model import RobotModel
from lab.controller.references import References


class Behaviour(Protocol):
    """Owns the references the tasks track and the contact schedule; built by a
    `BehaviourFactory(robot_model, q_standing)` from the robot's current state. A behaviour
    whose `update` changes nothing may say so with an attribute `idle = True` (Balance off a
    foot line): the session then skips the call and the touch sensing it would read."""

    name: str
    references: References
    lifts_feet: bool  # swings feet: the stack needs the swing_feet task to carry them
    kernel_ran: str  # which kernel ran the last update: native, python or none (native.py)

    def update(
        self, t: float, robot: RobotModel, command: np.ndarray, touching: np.ndarray
    ) -> None:
        """Advance the references to sim time `t` (s), given the model updated at this tick's
        state, the velocity command [vx (m/s), vy (m/s), yaw_rate (rad/s)] in the heading
        frame, and which feet touch the ground (measured)."""
        ...

    def configure(self, **options: object) -> None:
        """Set the behaviour's options (walking: step_height, cycle_time, footholds); raises
        ValueError or KeyError naming a bad or unknown option and changes nothing then."""
        ...

    def continue_from(self, previous: "Behaviour") -> None:
        """Take over what it can of the behaviour it replaces (walking: the gait in stride)."""
        ...


class NoOptions:
    """`configure` and `continue_from` of a behaviour with no options and nothing to take over."""

    name: str

    def configure(self, **options: object) -> None:
        """Accept no option: raises ValueError naming those given."""
        if options:
            raise ValueError(f"gait {self.name!r} takes no {', '.join(options)}")

    def continue_from(self, previous: Behaviour) -> None:
        """Start afresh: nothing of the previous behaviour carries over."""
