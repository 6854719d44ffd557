"""Hand tracking (`hand_tracking`): how closely the hands of the `hands` task follow their targets,
|p_ref − p| of the worst hand each tick (m): the largest and the RMS after the first HAND_SETTLE_S
of the run (the reach to a target set at the start), and at the end; the largest rotation error
|log₃(R_ref Rᵀ)| after the settling time (rad)."""

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from lab.controller.tasks.hands import hand_frame_ids

if TYPE_CHECKING:
    from lab.world.session import Session

HAND_SETTLE_S = 1.0  # s: errors before this sim time are the reach, not the tracking


class HandTrackingMetrics:
    def __init__(self, session: "Session") -> None:
        model = session.model.model
        hands = session.robot.description.hands
        self.frames = hand_frame_ids(model, tuple(frame for _, frame in hands))
        if not self.frames:
            raise ValueError(f"hand_tracking: robot {session.config.robot!r} has no [hands]")
        self.data = model.createData()
        self.errors: list[float] = []
        self.rotation_max = 0.0
        self.last = 0.0

    def update(self, session: "Session") -> None:
        model, refs = session.model, session.controller.references
        if len(refs.hand_position) != len(self.frames):
            return
        pin.framesForwardKinematics(model.model, self.data, model.q)
        position = rotation = 0.0
        for k, fid in enumerate(self.frames):
            placement = self.data.oMf[fid]
            position = max(position, np.linalg.norm(refs.hand_position[k] - placement.translation))
            e_r = pin.log3(refs.hand_rotation[k] @ placement.rotation.T)
            rotation = max(rotation, float(np.linalg.norm(e_r)))
        self.last = float(position)
        if session.time >= HAND_SETTLE_S:
            self.errors.append(self.last)
            self.rotation_max = max(self.rotation_max, rotation)

    def result(self) -> dict[str, float]:
        e = np.array(self.errors) if self.errors else np.zeros(1)
        return {
            "hand_error_max_m": float(e.max()),
            "hand_error_rms_m": float(np.sqrt(np.mean(e**2))),
            "hand_error_final_m": self.last,
            "hand_rotation_error_max_rad": self.rotation_max,
        }
