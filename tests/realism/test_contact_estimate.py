"""The haptic touch detector on the contact force estimated from torques (realism's
`contact_estimate`, lab/realism/contact_estimate.py and its C++ twin cpp/realism/
contact_estimate.cpp): the two agree, and the touchdowns it gives a trot are MuJoCo's."""

import math

import numpy as np
import pytest

from lab.controller.behaviours.gait import LegState
from lab.controller.model import BASE_DOF
from lab.realism.contact_estimate import ContactEstimator, TouchThresholds
from lab.realism.knobs import knobs_from, preset
from lab.world.session import Session, SessionConfig

TOUCH_FORCE = 1.0  # N: MuJoCo's contact, as the session's TOUCH_FORCE


def _session(robot: str, base: str, contact_estimate: int = 1) -> Session:
    realism = knobs_from(preset(base, robot), {"contact_estimate": contact_estimate})
    return Session(SessionConfig(robot=robot, realism=realism))


def _trot(session: Session, vx: float) -> None:
    session.handle("gait", {"name": "trot"})
    session.handle("velocity", {"vx": vx})


@pytest.mark.parametrize("robot", ["anymal", "hyq", "solo12"])
def test_the_python_and_cpp_detectors_agree_tick_by_tick_on_a_trot(robot: str) -> None:
    """On 2 s of `robot`'s trot at 0.5 m/s under `typical` (on MuJoCo's flags: the trot the
    detectors read), fed every tick the state the controller read (noisy, delayed), last tick's
    applied torques and MuJoCo's flags, the Python detector and its C++ twin with the robot's
    thresholds give the same normal forces, to 1e-9 of a foot's weight share (the same LU on
    a 3 × 3 block: they differ by rounding), and the same touch flags every tick."""
    kernel_module = pytest.importorskip("lab._kernel")
    session = _session(robot, "typical", contact_estimate=0)
    kernel = session.controller.native_kernel
    assert kernel is not None
    thresholds = TouchThresholds(**session.robot.description.touchdown)
    sizes = (session.config.timestep, session.model.na, len(session.model.contacts))
    python = ContactEstimator(thresholds, *sizes)
    native = kernel_module.ContactEstimator(
        **vars(thresholds), dt=sizes[0], n_joints=sizes[1], n_feet=sizes[2]
    )
    share = session.model.mass * 9.81 / sizes[2]
    for _ in range(500):
        session.tick()
    _trot(session, 0.5)
    worst, flips, lifted, released = 0.0, 0, 0, 0
    for _ in range(2000):
        applied = session.applied_tau.copy()  # last tick's
        session.tick()  # its model (the Python one and the kernel's) at the state it read
        v = session.model.v
        flags = session.plant.feet_touching(TOUCH_FORCE)
        a = python.update(session.model, applied, v[BASE_DOF:], flags)
        b = native.update(kernel, applied, v[BASE_DOF:], flags)
        worst = max(worst, float(np.abs(python.normal - native.normal).max()) / share)
        flips += int(np.any(a != b))
        lifted += int(not all(session.controller.references.contact_active))
        released += int(not a.all())
    assert not session.fell
    assert lifted > 500 and released > 300  # feet swung, and the detectors let them go
    assert worst < 1e-9 and flips == 0, (worst, flips)


@pytest.mark.parametrize(
    ("robot", "base", "within", "fraction", "false_max"),
    [
        ("anymal", "typical", 0.010, 0.9, 0),
        ("solo12", "ideal", 0.010, 0.9, 1),
        ("solo12", "typical", 0.020, 0.9, 1),
        ("hyq", "ideal", 0.010, 0.9, 0),
        ("hyq", "typical", 0.010, 0.9, 0),
    ],
)
def test_a_trot_on_the_estimate_lands_its_feet_when_mujoco_does(
    robot: str, base: str, within: float, fraction: float, false_max: int
) -> None:
    """Touchdown from the estimate (Raiola eq. 18 with the leg's acceleration, hysteresis, the
    gait's swing-down window): trotting 4 s at 0.5 m/s the robot does not fall, at most
    `false_max` touchdowns are detected while MuJoCo has the foot in the air, and `fraction` of
    the touchdowns come within `within` s of MuJoCo's contact onset (a leg that reaches past
    1.5 swing times without a detection lands anyway, gait.py; docs/realism.md has the 30 s
    numbers: HyQ, exact and `typical`, all within 10 ms, none false, since its thresholds
    came down to what its landing feet press; Solo12's did too, and under `typical`, whose
    joint friction takes part of a landing foot's press, 90 % land within 16 ms, hence 20)."""
    session = _session(robot, base)
    for _ in range(500):
        session.tick()
    _trot(session, 0.5)
    onset: dict[int, float] = {}
    latencies, false = [], 0
    was_stance = was_touch = None
    for _ in range(4000):
        session.tick()
        stance = [leg.state is LegState.STANCE for leg in session.behaviour.scheduler.legs]
        touch = session.plant.feet_touching(TOUCH_FORCE)
        if was_stance is not None:
            for i, (before, now) in enumerate(zip(was_stance, stance, strict=True)):
                if not before and touch[i] and not was_touch[i]:
                    onset[i] = session.time
                if before and not now:
                    onset.pop(i, None)
                if not before and now:  # a touchdown
                    detected = session.touch_estimate.touch[i]
                    false += int(detected and not touch[i])
                    latencies.append(session.time - onset.get(i, -math.inf))
        was_stance, was_touch = stance, touch
    assert not session.fell
    assert len(latencies) >= 12  # 4 s of trot: 4 steps per leg (HyQ), more for the others
    assert false <= false_max
    assert np.mean(np.array(latencies) <= within) >= fraction
