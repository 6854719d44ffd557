"""The `scene_motion` metric (Herzog 2016 §5.2.3): how the moving terrain moved and whether the
soles went with it.

For each scripted joint of a scene's moving bodies (`lab.scenes.terrain`), its lowest and highest
position over the run (`<joint>_min`, `<joint>_max`: m for a slide, rad for a hinge). For the soles,
the largest distance each one's centre moved from where it started, measured in the frame of the
scene's (first) moving body, or the world's in a static scene (`sole_slip_max_m`: a sole that
sticks to a rolling platform stays near 0). The scene's frame is read once a tick, not once a
sole.
"""

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from lab.world.session import Session


class SceneMotionMetrics:
    def __init__(self, session: "Session") -> None:
        joints = session.plant.scripted_joint_positions()
        self.low = dict.fromkeys(joints, np.inf)
        self.high = dict.fromkeys(joints, -np.inf)
        self.start = self._local(session)
        self.slip = 0.0

    @staticmethod
    def _local(session: "Session") -> list[np.ndarray]:
        """Each contact's position in the frame of the scene's first moving body (or the
        world)."""
        position, rotation = session.plant.terrain_frame()
        return [rotation.T @ (p - position) for p in session.model.contact_positions]

    def update(self, session: "Session") -> None:
        for name, value in session.plant.scripted_joint_positions().items():
            self.low[name] = min(self.low[name], value)
            self.high[name] = max(self.high[name], value)
        for local, start in zip(self._local(session), self.start, strict=True):
            moved = local - start
            self.slip = max(self.slip, math.sqrt(moved @ moved))  # as np.linalg.norm computes it

    def result(self) -> dict[str, float]:
        ranges = {}
        for name in self.low:
            ranges[f"{name}_min"] = self.low[name]
            ranges[f"{name}_max"] = self.high[name]
        return {**ranges, "sole_slip_max_m": self.slip}
