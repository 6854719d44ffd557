"""Hand targets: where each hand of the `hands` task (tasks/hands.py) should be, in time.

A target is a pose held still, or its position moving on a circle about a centre at a constant
rate (a reach that never settles, to measure tracking), in the world or in the trunk's heading
frame (tasks/hands.py: it moves with the robot). `HandTargets` holds one per hand and writes
them, with the velocity and acceleration fed forward, into a References' hand rows each tick.
"""

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from lab.controller.references import References
from lab.controller.tasks.hands import hand_frame_ids
from lab.protocol import HandCommand
from lab.protocol.commands import HandFrame


@dataclass(frozen=True)
class HandTarget:
    """A hand's target: `position` (m) and `rotation`; with `radius` > 0 the position moves on
    the circle of that radius about `position`, in the plane normal to `axis`, one turn per
    `period` (s) counter-clockwise about `axis`, from `start` (s, sim time), starting at the
    centre + radius × the first in-plane axis. All in `frame`: "world", or "heading" (the
    trunk's heading frame)."""

    position: np.ndarray
    rotation: np.ndarray
    radius: float = 0.0
    period: float = 1.0
    axis: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    start: float = 0.0
    frame: HandFrame = "world"

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration of the target at sim time t."""
        zero = np.zeros(3)
        if self.radius == 0.0:
            return self.position, zero, zero
        u, w = _plane(self.axis)
        omega = 2.0 * math.pi / self.period
        phase = omega * (t - self.start)
        c, s = math.cos(phase), math.sin(phase)
        offset = self.radius * (c * u + s * w)
        velocity = self.radius * omega * (-s * u + c * w)
        return self.position + offset, velocity, -(omega**2) * offset


def _plane(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors u, w with (u, w, axis/|axis|) right-handed."""
    n = axis / np.linalg.norm(axis)
    helper = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(helper, n)
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def _report(name: str, target: HandTarget) -> dict:
    return {
        "name": name,
        "position": target.position.tolist(),
        "rpy": pin.rpy.matrixToRpy(target.rotation).tolist(),
        "radius": target.radius,
        "period": target.period,
        "frame": target.frame,
    }


class HandTargets:
    """One target per named hand, in the order of the references' hand rows."""

    def __init__(self, names: tuple[str, ...], targets: list[HandTarget]) -> None:
        self.names = names
        self.targets = targets
        self._written: References | None = None  # the references last written, while current

    @classmethod
    def holding(
        cls, model: pin.Model, q: np.ndarray, hands: tuple[tuple[str, str], ...]
    ) -> "HandTargets":
        """Each hand (name, frame) held where it is at configuration q."""
        data = model.createData()
        pin.framesForwardKinematics(model, data, q)
        targets = []
        for fid in hand_frame_ids(model, tuple(frame for _, frame in hands)):
            placement = data.oMf[fid]
            targets.append(HandTarget(placement.translation.copy(), placement.rotation.copy()))
        return cls(tuple(name for name, _ in hands), targets)

    def target(self, name: str) -> HandTarget:
        """The target of hand `name`; raises KeyError naming the hands for another name."""
        return self.targets[self._index(name)]

    def _index(self, name: str) -> int:
        if name not in self.names:
            hands = ", ".join(self.names) or "none"
            raise KeyError(f"unknown hand {name!r} (hands: {hands})")
        return self.names.index(name)

    def set(self, name: str, target: HandTarget) -> None:
        """Replace the target of hand `name`; raises KeyError naming the hands for another
        name."""
        self.targets[self._index(name)] = target
        self._written = None

    def command(self, command: HandCommand, t: float) -> dict:
        """Apply a `hand` command at sim time t (the circle starts then); the new target as
        the reply reports it. Raises KeyError naming the hands for an unknown one, changing
        nothing."""
        old = self.target(command.name)
        rotation = old.rotation if command.rpy is None else pin.rpy.rpyToMatrix(*command.rpy)
        target = HandTarget(
            np.array(command.position, dtype=float),
            rotation,
            command.radius,
            command.period,
            np.array(command.axis, dtype=float),
            t,
            command.frame,
        )
        self.set(command.name, target)
        return _report(command.name, target)

    def report(self) -> list[dict]:
        """Each hand's target as `info` and the `hand` reply report it."""
        return [_report(name, t) for name, t in zip(self.names, self.targets, strict=True)]

    def write(self, refs: References, t: float) -> None:
        """The targets at sim time t into `refs`' hand rows (allocated when their count
        differs); nothing to do when these references already hold still targets."""
        if refs is self._written:
            return
        n = len(self.targets)
        if len(refs.hand_position) != n or len(refs.hand_heading) != n:
            refs.hand_position = np.zeros((n, 3))
            refs.hand_velocity = np.zeros((n, 3))
            refs.hand_acceleration = np.zeros((n, 3))
            refs.hand_rotation = np.zeros((n, 3, 3))
            refs.hand_heading = np.zeros(n, dtype=bool)
        for k, target in enumerate(self.targets):
            p, v, a = target.at(t)
            refs.hand_position[k] = p
            refs.hand_velocity[k] = v
            refs.hand_acceleration[k] = a
            refs.hand_rotation[k] = target.rotation
            refs.hand_heading[k] = target.frame == "heading"
        moving = any(target.radius > 0.0 for target in self.targets)
        self._written = None if moving else refs
