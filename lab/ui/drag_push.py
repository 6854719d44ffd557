"""Click-and-drag push: a spring from the grab point on the body towards the pointer.

`DragPush` follows one drag (the body grabbed, the grab point in the body's frame, the
pointer); the render loop turns it into a short `push` at the grab point every refresh while
the drag lasts.
"""

from dataclasses import dataclass
from typing import Protocol

import numpy as np
import viser.transforms as vtf

from lab.protocol import PushCommand

DRAG_PUSH_S = 0.25  # duration of each drag push; refreshed (app.REFRESH_S) while dragging


@dataclass(frozen=True)
class Spring:
    stiffness: float = 400.0  # N/m
    max_force: float = 300.0  # N


def spring_force(grab: np.ndarray, pointer: np.ndarray, spring: Spring) -> np.ndarray:
    """World force k (pointer - grab), its magnitude capped at `spring.max_force`."""
    f = spring.stiffness * (np.asarray(pointer, float) - np.asarray(grab, float))
    norm = float(np.linalg.norm(f))
    if norm > spring.max_force:
        f *= spring.max_force / norm
    return f


class Placements(Protocol):
    """Where the drawn robot's links are (`robot_view.RobotView`)."""

    def frame_placement(self, frame: str) -> vtf.SE3: ...


@dataclass(frozen=True)
class Grab:
    """A drag in progress: the body grabbed, the grab point in its frame, the pointer (world)."""

    body: str
    local: np.ndarray
    pointer: np.ndarray


class DragPush:
    """The drag in progress (None when there is none) and the spring it pushes with."""

    def __init__(self, spring: Spring = Spring()) -> None:
        self.grab: Grab | None = None
        self.spring = spring

    def move(
        self,
        phase: str,
        start: np.ndarray,
        pointer: np.ndarray,
        body: str,
        robot: Placements,
    ) -> None:
        """A drag event on `body` (a pushable body: the link dragged, or the base): `phase`
        start / update / end, the world points where it started and where the pointer is."""
        if phase == "end":
            self.grab = None
        elif phase == "start" or self.grab is None or self.grab.body != body:
            local = robot.frame_placement(body).inverse().apply(np.asarray(start, float))
            self.grab = Grab(body, local, np.asarray(pointer, float))
        else:
            self.grab = Grab(self.grab.body, self.grab.local, np.asarray(pointer, float))

    def command(self, robot: Placements) -> tuple[PushCommand, np.ndarray, np.ndarray] | None:
        """The push of the drag in progress, with its grab point and the pointer (world)."""
        grab = self.grab
        if grab is None:
            return None
        point = robot.frame_placement(grab.body).apply(grab.local)
        fx, fy, fz = spring_force(point, grab.pointer, self.spring).tolist()
        x, y, z = point.tolist()
        return PushCommand(grab.body, (fx, fy, fz), DRAG_PUSH_S, (x, y, z)), point, grab.pointer
