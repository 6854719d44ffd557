"""The Behaviour protocol, and the defaults of a behaviour that takes no options."""

from typing import TYPE_CHECKING, Protocol

import numpy as np

from lab.controller.model import RobotModel
from lab.controller.references import References

if TYPE_CHECKING:
    from lab._kernel import NativeBehaviour


class Behaviour(Protocol):
    """Owns the references the tasks track and the contact schedule; built by a
    `BehaviourFactory(robot_model, q_standing)` from the robot's current state. A behaviour
    whose `update` changes nothing may say so with an attribute `idle = True` (Balance off a
    foot line): the session then skips the call and the touch sensing it would read."""

    name: str
    references: References
    lifts_feet: bool  # swings feet: the stack needs the swing_feet task to carry them

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


class NativeTicking:
    """Declares a behaviour whose tick has a native twin (a `_kernel.NativeBehaviour`,
    cpp/behaviours/native_behaviour.hpp) that the server's native tick (lab/server/native_tick.py)
    runs inside its one crossing. The Python object keeps the state: the twin reads it when
    `native_stale` says it changed since the twin's last tick, and writes it back after each."""

    _native: "NativeBehaviour | None" = None  # the twin (None: not built, or not for this robot)
    _native_stale = True  # this object's state changed since the twin last read it

    def native_twin(self) -> "NativeBehaviour | None":
        """The twin that can run this tick in C++, or None when the Python tick must run."""
        return self._native

    @property
    def native_stale(self) -> bool:
        """Whether the twin must read this object's state before its next tick."""
        return self._native_stale

    def native_ran(self) -> None:
        """The twin ran a tick: it holds this object's state now."""
        self._native_stale = False
