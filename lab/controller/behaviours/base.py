"""The Behaviour protocol, and the defaults of a behaviour that takes no options."""

from typing import Protocol

import numpy as np

from lab.controller.model import RobotModel
from lab.controller.references import References


class Prediction(Protocol):
    """A stepping planner's last answer, in the heading frame (world origin, m): when it was
    made (s), the footstep, and the CoM's predicted (t, x, ẋ) rows along the forward and lateral
    axes (Kim 2016 Figs. 4–5)."""

    @property
    def t(self) -> float: ...
    @property
    def foot(self) -> np.ndarray: ...
    @property
    def forward(self) -> np.ndarray: ...
    @property
    def lateral(self) -> np.ndarray: ...


class Stepping(Protocol):
    """What a point-foot stepping behaviour reports (telemetry's phase portraits, the `stepping`
    metric): touchdowns, swings the planner cut short or lengthened, its last prediction."""

    @property
    def steps(self) -> int: ...
    @property
    def shortened(self) -> int: ...
    @property
    def lengthened(self) -> int: ...
    @property
    def prediction(self) -> Prediction | None: ...


class Behaviour(Protocol):
    """Owns the references the tasks track and the contact schedule; built by a
    `BehaviourFactory(robot_model, q_standing)` from the robot's current state. What the session
    and telemetry read of it beyond the references is declared here, never probed:
    `BehaviourDefaults` gives the plain answers."""

    # Read, never set, through this protocol: a behaviour may declare a narrower type (a
    # stance's SoleReferences, a twin's KernelRan).
    @property
    def name(self) -> str:
        """The gait name it is built under (BEHAVIOURS)."""
        ...

    @property
    def references(self) -> References:
        """The references it owns and updates."""
        ...

    @property
    def lifts_feet(self) -> bool:
        """Whether it swings feet: the stack needs the swing_feet task to carry them."""
        ...

    @property
    def kernel_ran(self) -> str:
        """Which kernel ran the last update: native, python or none (native.py)."""
        ...

    @property
    def stack_preset(self) -> str | None:
        """The stack preset it brings onto a stack without swing_feet; None: the lab's walking
        one."""
        ...

    @property
    def idle(self) -> bool:
        """Whether `update` changes nothing now (Balance off a foot line): the session then
        skips the call and the touch sensing it would read."""
        ...

    @property
    def stepping(self) -> Stepping | None:
        """Its stepping report when it steps on point feet (biped_step), else None."""
        ...

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


class BehaviourDefaults:
    """The declarations of a behaviour with nothing special to declare: its `update` always
    runs, it brings no stack preset of its own, and it does not step."""

    stack_preset: str | None = None

    @property
    def idle(self) -> bool:
        """Never idle: `update` runs every tick."""
        return False

    @property
    def stepping(self) -> Stepping | None:
        """Not a stepping behaviour."""
        return None


class NoOptions(BehaviourDefaults):
    """`configure` and `continue_from` of a behaviour with no options and nothing to take over."""

    name: str

    def configure(self, **options: object) -> None:
        """Accept no option: raises ValueError naming those given."""
        if options:
            raise ValueError(f"gait {self.name!r} takes no {', '.join(options)}")

    def continue_from(self, previous: Behaviour) -> None:
        """Start afresh: nothing of the previous behaviour carries over."""
