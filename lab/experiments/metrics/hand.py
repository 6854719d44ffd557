"""Hand tracking (`hand_tracking`): how closely the hands of the `hands` task follow their targets,
|p_ref − p| of the worst hand each tick (m), the target in world axes (a heading-frame target
placed at the trunk's pose of that tick, tasks/hands.py): the largest and the RMS after the first
HAND_SETTLE_S of the run (the reach to a target set at the start), and at the end; the largest
rotation error |log₃(R_ref Rᵀ)| after the settling time (rad).

In a run with pushes it also reports the largest error from the first push's start on
(`hand_error_push_max_m`: the push and the hand's recovery from it) and how long after the last
push ended the hand was back within HAND_RECOVERED_M of its target for good
(`hand_recovery_s`: 0 when it never left; up to the end of the run when it never came back).
"""

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from lab.controller.tasks.hands import BASE_JOINT, hand_frame_ids, world_target

if TYPE_CHECKING:
    from lab.world.session import Session

HAND_SETTLE_S = 1.0  # s: errors before this sim time are the reach, not the tracking
HAND_RECOVERED_M = 0.01  # m: a pushed hand is back once within this of its target for good


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
        self.push_end: float | None = None  # when the last push seen ends (s)
        self.push_max = 0.0
        self.last_away = 0.0  # the last tick's time the hand was farther than HAND_RECOVERED_M
        self.time = 0.0

    def update(self, session: "Session") -> None:
        model, refs = session.model, session.controller.references
        if len(refs.hand_position) != len(self.frames):
            return
        pin.framesForwardKinematics(model.model, self.data, model.q)
        base = self.data.oMi[BASE_JOINT]
        heading = refs.hand_heading if len(refs.hand_heading) else np.zeros(len(self.frames), bool)
        position = rotation = 0.0
        for k, fid in enumerate(self.frames):
            placement = self.data.oMf[fid]
            p_ref, R_ref = world_target(
                base, refs.hand_position[k], refs.hand_rotation[k], bool(heading[k])
            )
            position = max(position, float(np.linalg.norm(p_ref - placement.translation)))
            e_r = pin.log3(R_ref @ placement.rotation.T)
            rotation = max(rotation, float(np.linalg.norm(e_r)))
        self.last, self.time = position, session.time
        if session.time >= HAND_SETTLE_S:
            self.errors.append(self.last)
            self.rotation_max = max(self.rotation_max, rotation)
        if session.pushes:
            self.push_end = max(push.ends_at for push in session.pushes.values())
        if self.push_end is not None:
            self.push_max = max(self.push_max, position)
            if position > HAND_RECOVERED_M:
                self.last_away = session.time

    def result(self) -> dict[str, float]:
        e = np.array(self.errors) if self.errors else np.zeros(1)
        out = {
            "hand_error_max_m": float(e.max()),
            "hand_error_rms_m": float(np.sqrt(np.mean(e**2))),
            "hand_error_final_m": self.last,
            "hand_rotation_error_max_rad": self.rotation_max,
        }
        if self.push_end is not None:
            away = self.time if self.last > HAND_RECOVERED_M else self.last_away
            out["hand_error_push_max_m"] = self.push_max
            out["hand_recovery_s"] = max(0.0, away - self.push_end)
        return out
