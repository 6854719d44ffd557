"""Walking behaviours in a real session (MuJoCo + WBC): feet really swing and land, contact forces
change smoothly, gait commands are validated and switch gait in stride."""

import numpy as np
import pytest

from lab.controller.behaviours.gait import LegState
from lab.stack_presets import load_stack_preset
from lab.world.session import Session, SessionConfig

GRAVITY = 9.81


def _session(robot: str = "anymal", preset: str = "raiola_s3") -> Session:
    stack = load_stack_preset(preset)
    config = SessionConfig(robot=robot, stack=stack.levels, gains=stack.gains, method=stack.method)
    return Session(config)


@pytest.fixture(scope="module")
def trotting() -> dict:
    """ANYmal trots in place for 1.6 s under S3; per tick: foot heights, QP normal forces,
    leg states."""
    session = _session()
    assert session.handle("gait", {"name": "trot"}) == {"ok": True}
    walking = session.behaviour
    heights, normals, states = [], [], []
    for _ in range(1600):
        session.tick()
        heights.append(session.model.contact_positions[:, 2].copy())
        normals.append(session.forces.reshape(-1, 3)[:, 2].copy())
        states.append([leg.state for leg in walking.scheduler.legs])
    return {
        "session": session,
        "walking": walking,
        "heights": np.array(heights),
        "normals": np.array(normals),
        "states": states,
        "weight": session.model.mass * GRAVITY,
    }


def test_trotting_feet_lift_to_the_step_height_and_land_again(trotting: dict) -> None:
    session, walking, heights = trotting["session"], trotting["walking"], trotting["heights"]
    assert not session.fell
    assert session.qp_failures == 0
    ground = heights[0]
    lift = heights.max(axis=0) - ground
    assert np.all(lift > 0.7 * walking.step_height)
    assert np.all(lift < 1.3 * walking.step_height)
    # Every foot landed again: back within 1 cm of the ground at some point after its peak.
    for foot in range(4):
        peak = int(np.argmax(heights[:, foot]))
        assert np.min(heights[peak:, foot] - ground[foot]) < 0.01
    swung = [sum(s[i] is not LegState.STANCE for s in trotting["states"]) for i in range(4)]
    assert min(swung) > 400  # each leg in the air for > 0.4 s of the 1.6 s


def test_contact_forces_ramp_without_jumps(trotting: dict) -> None:
    normals, weight = trotting["normals"], trotting["weight"]
    states = trotting["states"]
    airborne = np.array([[s is not LegState.STANCE for s in tick] for tick in states])
    assert np.all(np.abs(normals[airborne]) < 1e-6)  # a swinging foot carries nothing
    # Loads move between the diagonal pairs over the ramps, never in one tick (after the first
    # 10 ms, in which the controller takes over from the initial state).
    assert np.max(np.abs(np.diff(normals[10:], axis=0))) < 0.1 * weight
    assert np.max(normals) > 0.4 * weight  # a stance pair does carry the robot


def test_gait_options_are_validated_and_a_bad_one_changes_nothing() -> None:
    session = _session("solo12")
    assert session.handle("gait", {"name": "trot", "step_height": 0.04})["ok"]
    before = session.behaviour
    for payload, needle in (
        ({"name": "trot", "step_height": 0.3}, "step_height"),  # longer than Solo's legs
        ({"name": "trot", "cycle_time": 0.0}, "cycle_time"),
        ({"name": "trot", "footholds": "psychic"}, "psychic"),
        ({"name": "stand", "step_height": 0.05}, "stand"),
        ({"name": "trot", "speed": 2}, "speed"),
    ):
        reply = session.handle("gait", payload)
        assert reply["ok"] is False
        assert needle in reply["error"]
        assert session.behaviour is before
    assert session.behaviour.step_height == 0.04


def test_switching_gait_continues_the_stride(trotting: dict) -> None:
    session = trotting["session"]
    for _ in range(150):
        session.tick()
    trot = session.behaviour
    in_air = [leg.state is not LegState.STANCE for leg in trot.scheduler.legs]
    liftoff = trot.liftoff.copy()
    assert any(in_air)
    reply = session.handle("gait", {"name": "crawl", "cycle_time": 1.5, "footholds": "raibert"})
    assert reply == {"ok": True}
    crawl = session.behaviour
    assert crawl.name == "crawl" and crawl.cycle_time == 1.5 and crawl.footholds == "raibert"
    assert [leg.state is not LegState.STANCE for leg in crawl.scheduler.legs] == in_air
    assert crawl.liftoff == pytest.approx(liftoff)
    assert crawl.step_height == trot.step_height
