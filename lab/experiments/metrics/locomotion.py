"""Locomotion metrics of a scenario, whatever the behaviour: velocity tracking, trunk attitude,
distance, pushes.

Velocities are measured in the heading frame (the base frame turned about z by the base yaw) and
compared with the session's velocity command. Averages start after SETTLE_TIME of simulated time,
so that the start from standing does not count. A push counts as survived when the robot did not
fall between its end and the start of the next push (or the end of the run), and stood at least
SURVIVE_TIME of that: a robot that falls 1.2 s after a kick, before anything else happened to it,
did not survive the kick. A push followed sooner than SURVIVE_TIME by another one is judged with it.
"""

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

if TYPE_CHECKING:
    from lab.world.session import Session

SETTLE_TIME = 1.0  # s
SURVIVE_TIME = 1.0  # s, the shortest time a push is watched for a fall


class LocomotionMetrics:
    """Mean velocity-tracking error, mean |roll| and |pitch|, distance travelled, largest push."""

    def __init__(self, session: "Session") -> None:
        self.start = session.model.q[:2].copy()
        self.end = self.start.copy()
        self.samples = 0
        self.error_sum = 0.0
        self.velocity_sum = np.zeros(3)
        self.command_sum = np.zeros(3)
        self.attitude_sum = np.zeros(2)
        self.impulses: dict[str, float] = {}  # body -> impulse so far of its push (N s)
        self.ended: list[tuple[float, float]] = []  # (end time, impulse) of pushes not judged
        self.largest_survived = 0.0
        self.time = 0.0
        self.fell = False

    def update(self, session: "Session") -> None:
        model = session.model
        self.end = model.q[:2].copy()
        self.time, self.fell = session.time, session.fell
        dt = session.config.timestep
        if self.fell:
            self.ended.clear()  # the pushes since the last judged one were not survived
        elif set(session.pushes) - set(self.impulses):  # a push starts: judge the earlier ones
            self.largest_survived = self._largest_survived()
            self.ended = [(end, i) for end, i in self.ended if self.time < end + SURVIVE_TIME]
        for body, push in session.pushes.items():
            impulse = dt * float(np.linalg.norm(push.force))
            self.impulses[body] = self.impulses.get(body, 0.0) + impulse
        for body in set(self.impulses) - set(session.pushes):
            self.ended.append((session.time, self.impulses.pop(body)))
        if session.time < SETTLE_TIME:
            return
        roll, pitch, yaw = pin.rpy.matrixToRpy(model.base_rotation)
        c, s = np.cos(yaw), np.sin(yaw)
        v = model.base_linear_velocity_world
        measured = np.array(
            [c * v[0] + s * v[1], -s * v[0] + c * v[1], model.base_angular_velocity_world[2]]
        )
        self.samples += 1
        self.error_sum += float(np.linalg.norm(measured[:2] - session.velocity[:2]))
        self.velocity_sum += measured
        self.command_sum += session.velocity
        self.attitude_sum += np.abs([roll, pitch])

    def _largest_survived(self) -> float:
        """The largest push survived, counting the finished pushes watched for SURVIVE_TIME."""
        watched = [i for end, i in self.ended if self.time >= end + SURVIVE_TIME]
        return max([self.largest_survived, *watched]) if not self.fell else self.largest_survived

    def result(self) -> dict[str, float]:
        n = max(self.samples, 1)
        mean_v, mean_cmd = self.velocity_sum / n, self.command_sum / n
        return {
            "distance_m": float(np.linalg.norm(self.end - self.start)),
            "mean_velocity_error_mps": self.error_sum / n,
            "mean_velocity_drift_mps": float(np.linalg.norm(mean_v[:2] - mean_cmd[:2])),
            "mean_vx_mps": float(mean_v[0]),
            "mean_vy_mps": float(mean_v[1]),
            "mean_yaw_rate_radps": float(mean_v[2]),
            "mean_abs_roll_rad": float(self.attitude_sum[0] / n),
            "mean_abs_pitch_rad": float(self.attitude_sum[1] / n),
            "largest_push_survived_ns": self._largest_survived(),  # the run ended: judge all
        }
