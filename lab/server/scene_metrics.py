"""The `scene_motion` metric (Herzog 2016 §5.2.3): how the moving terrain moved and whether the
soles went with it.

For each scripted joint of a scene's moving bodies (`lab.scenes.terrain`), its lowest and highest
position over the run (`<joint>_min`, `<joint>_max`: m for a slide, rad for a hinge). For the soles,
the largest distance each one's centre moved from where it started, measured in the frame of the
scene's (first) moving body, or the world's in a static scene (`sole_slip_max_m`: a sole that
sticks to a rolling platform stays near 0).
"""

from typing import TYPE_CHECKING

import numpy as np

from lab.scenes.terrain import scripted_joint_name

if TYPE_CHECKING:
    from lab.server.session import Session


class SceneMotionMetrics:
    def __init__(self, session: "Session") -> None:
        plant = session.plant
        m = plant.mj_model
        scripted = plant.moving_terrain
        bodies = scripted.bodies
        names = [scripted_joint_name(b.name, k) for b in bodies for k in range(len(b.joints))]
        self.joints = [(name, m.joint(name).qposadr[0]) for name in names]
        self.low = {name: np.inf for name, _ in self.joints}
        self.high = {name: -np.inf for name, _ in self.joints}
        self.under = scripted.body_ids[0] if scripted.body_ids else 0  # 0: the world
        self.start = [self._local(session, i) for i in range(len(session.model.contacts))]
        self.slip = 0.0

    def _local(self, session: "Session", i: int) -> np.ndarray:
        d, body = session.plant.mj_data, self.under
        return d.xmat[body].reshape(3, 3).T @ (session.model.contact_positions[i] - d.xpos[body])

    def update(self, session: "Session") -> None:
        qpos = session.plant.mj_data.qpos
        for name, address in self.joints:
            self.low[name] = min(self.low[name], float(qpos[address]))
            self.high[name] = max(self.high[name], float(qpos[address]))
        for i, start in enumerate(self.start):
            self.slip = max(self.slip, float(np.linalg.norm(self._local(session, i) - start)))

    def result(self) -> dict[str, float]:
        ranges = {}
        for name, _ in self.joints:
            ranges[f"{name}_min"] = self.low[name]
            ranges[f"{name}_max"] = self.high[name]
        return {**ranges, "sole_slip_max_m": self.slip}
