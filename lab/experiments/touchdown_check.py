"""Haptic touchdown on the contact force estimated from torques, measured (docs/realism.md, the
`contact_estimate` knob): the standard push campaign standing (0.3 m g for 0.2 s from the left,
right, front and back, 1.5 s apart), then a trot at 0.5 m/s, with `contact_estimate = 1` over a
preset; per touchdown the gait made, whether MuJoCo's foot touched then (or at all since its
lift-off: a foot that bounced touched before), whether the detector fired (else the leg gave up
reaching, gait.py) and its delay after MuJoCo's contact onset.

    .venv/bin/python -m lab.experiments.touchdown_check ROBOT PRESET [TROT_SECONDS]
"""

import math
import sys

import numpy as np

from lab.controller.behaviours.gait import LegState
from lab.controller.behaviours.walking import Walking
from lab.realism.knobs import knobs_from, preset
from lab.world.session import Session, SessionConfig

G = 9.81
TOUCH_FORCE = 1.0  # N: MuJoCo's contact, as the session's


def touchdown_check(robot: str, base: str, trot_seconds: float = 30.0) -> dict:
    """Run the campaign (module docstring); its outcome and touchdown statistics."""
    realism = knobs_from(preset(base, robot), {"contact_estimate": 1})
    session = Session(SessionConfig(robot=robot, realism=realism))
    dt = session.config.timestep
    push = 0.3 * session.model.mass * G

    def run(seconds: float, each_tick=None) -> bool:
        for _ in range(round(seconds / dt)):
            session.tick()
            if each_tick is not None:
                each_tick()
            if session.fell:
                return False
        return True

    run(1.0)
    for force in ([0, push, 0], [0, -push, 0], [push, 0, 0], [-push, 0, 0]):
        reply = session.handle(
            "push", {"body": session.robot.base_link, "force": force, "duration": 0.2}
        )
        if not reply["ok"]:  # never a campaign that silently pushed nothing
            raise RuntimeError(f"touchdown_check: the push was refused: {reply['error']}")
        if not run(1.5):
            return {"robot": robot, "preset": base, "fell_at_s": session.time}
    session.handle("gait", {"name": "trot"})
    session.handle("velocity", {"vx": 0.5})
    onset: dict[int, float] = {}
    delays: list[float] = []
    false = in_air = gave_up = 0
    last: list = []

    def each_tick() -> None:
        behaviour, estimator = session.behaviour, session.touch_estimate
        assert isinstance(behaviour, Walking) and behaviour.scheduler is not None
        assert estimator is not None  # the knob is on: the tick made it
        stance = [leg.state is LegState.STANCE for leg in behaviour.scheduler.legs]
        touch = session.plant.feet_touching(TOUCH_FORCE)
        if last:
            was_stance, was_touch = last
            for i, (before, now) in enumerate(zip(was_stance, stance, strict=True)):
                if not before and touch[i] and not was_touch[i]:
                    onset[i] = session.time
                if before and not now:
                    onset.pop(i, None)
                if not before and now:
                    nonlocal false, in_air, gave_up
                    detected = bool(estimator.touch[i])
                    false += int(detected and not touch[i])
                    in_air += int(detected and i not in onset)  # no contact since lift-off
                    gave_up += int(not detected)
                    delays.append(session.time - onset.get(i, -math.inf))
        last[:] = [stance, touch]

    x0 = float(session.plant.state()[0][0])
    survived = run(trot_seconds, each_tick)
    delays_ms = 1e3 * np.array(delays)
    return {
        "robot": robot,
        "preset": base,
        "tick": session.tick_report()["tick"],  # the path that ran (python: its note says why)
        "fell_at_s": None if survived else session.time,
        "walked_m": float(session.plant.state()[0][0]) - x0,
        "touchdowns": len(delays),
        "false_touchdowns": false,  # detected while MuJoCo's foot was off the ground
        "in_air": in_air,  # of them, with no MuJoCo contact since lift-off (not a bounce)
        "gave_up": gave_up,
        "delay_ms_median": float(np.median(delays_ms)) if delays else math.nan,
        "within_10_ms": float(np.mean(delays_ms <= 10.0)) if delays else math.nan,
    }


if __name__ == "__main__":
    seconds = float(sys.argv[3]) if len(sys.argv) > 3 else 30.0
    print(touchdown_check(sys.argv[1], sys.argv[2], seconds))
