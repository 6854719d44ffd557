"""The support task: feet in contact do not accelerate (Raiola eq. 7)."""

from lab.controller.model import RobotModel
from lab.controller.references import References
from lab.controller.rows import JacobianRows, PerContactSet
from lab.controller.tasks.base import Task, TaskGains, TaskRows


class ContactTask(Task):
    """Feet in contact do not accelerate: J_c q̈ = −J̇_c v − kd J_c v (Raiola eq. 7), point feet
    in world axes, flat feet in the sole frame. The error is the contact velocity J_c v (m/s,
    rad/s).

    kd = 0 is the paper's task; a small kd damps the drift of a foot that slipped.
    """

    name = "contact"
    GAINS = ("kd", "weight")

    def __init__(self, gains: TaskGains | None = None) -> None:
        super().__init__(gains)
        self._support = PerContactSet(JacobianRows.of)

    def rows(self, robot: RobotModel, refs: References) -> TaskRows:
        support = self._support.get(robot, refs.contact_active)
        velocity = support.write(robot).dot(robot.v)
        b = -robot.Jc_dot_v[support.index]
        if self.gains.kd:
            b -= self.gains.kd * velocity
        return TaskRows(support.view, b, velocity)
