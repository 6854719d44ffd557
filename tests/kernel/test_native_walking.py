"""The walking behaviour's native tick (cpp/behaviours/walking.cpp, gait.cpp, footholds.cpp,
swing.cpp, leg_posture.cpp) against its Python steps (walking.py and the modules it calls), and a
native trot in a session. Skipped when the kernel is not built."""

import functools

import numpy as np
import pytest

from lab.controller.behaviours import walking as walking_module
from lab.controller.behaviours.gait import GAITS, LegState
from lab.controller.behaviours.walking import Walking
from lab.controller.model import RobotModel
from lab.description import ROBOT_NAMES, load_description
from lab.robot import build_robot
from lab.world.session import Session, SessionConfig
from tests.helpers.native_ticks import recording, scripted_state, tick_native_and_mixed

pytest.importorskip("lab._kernel", reason="the native kernel is not built (./dev builds it)")

TOL = 1e-9  # relative to 1 + |value|: the same steps, another float order
RECORDED_TICKS = 700  # a trot cycle (0.6 s on ANYmal) and more: lift-offs and touchdowns
CONFIGURE_AT = 300  # a new step height mid-stride: the native state is read again
NUMB_FROM = 150  # the crawl feels no ground from this tick on
WALKERS = tuple(  # every robot with four point feet: the walking gaits' robots
    name
    for name in ROBOT_NAMES
    if [c.kind for c in load_description(name).contacts] == ["point"] * 4
)
# When a scripted swinging foot touches down, as a fraction of its planned swing, per leg:
# early, on time, late (the leg reaches) and nearly on time.
TOUCHDOWN_AT = (0.8, 1.0, 1.3, 0.95)
SCRIPTED_DT = 0.002  # s between scripted ticks


@functools.cache
def recorded_trot() -> tuple:
    """What a Python-kernel ANYmal session's walking behaviour was given per tick while it
    trotted and turned under Raiola S3: (t, q, v, command, touching)."""
    session = Session(SessionConfig(robot="anymal", kernel="python"))
    session.handle("gait", {"name": "trot"})
    session.handle("velocity", {"vx": 0.4, "vy": 0.05, "yaw_rate": 0.3})
    calls = recording(session)
    for _ in range(RECORDED_TICKS):
        session.tick()
    assert not session.fell
    return session.robot, tuple(calls)


def walking_state(walking: Walking) -> dict[str, object]:
    """Everything a walking tick changes: its state, the leg posture's and the references."""
    refs, legs = walking.references, walking.scheduler.legs
    return {
        "t": walking.t,
        "command": walking.command,
        "yaw_ref": walking.yaw_ref,
        "measured_twist": walking.measured_twist,
        "liftoff": walking.liftoff,
        "phase": (walking.scheduler.phase, walking.scheduler.t),
        "legs": [
            (leg.since, leg.swing_duration, -1.0 if leg.unload_start is None else leg.unload_start)
            for leg in legs
        ],
        "posture": walking.posture.position,
        "posture_velocity": walking.posture.velocity,
        "foot_rotations": walking.posture._rotations,
        "foot_references": walking.foot_references,
        "normal_force_max": refs.normal_force_max,
        "posture_weight": refs.posture_weight,
        "base_height": refs.base_height,
        "base_rotation": refs.base_rotation,
        "base_angular_velocity": refs.base_angular_velocity,
        "base_linear_velocity": refs.base_linear_velocity,
        "com": refs.com,
        "com_velocity": refs.com_velocity,
    }


def flat_state(walking: Walking) -> tuple[np.ndarray, np.ndarray]:
    """walking_state's values in one vector, and each entry's tolerance: TOL relative to
    1 + the largest magnitude of its field (a tick's comparison is then one numpy call)."""
    values = [np.ravel(np.asarray(value, float)) for value in walking_state(walking).values()]
    tolerances = [np.full(len(v), TOL * (1.0 + np.abs(v).max(initial=0.0))) for v in values]
    return np.concatenate(values), np.concatenate(tolerances)


def assert_same_walking(native: Walking, python: Walking, tick: int) -> None:
    legs = [(leg.state, leg.last_cycle) for leg in native.scheduler.legs]
    assert legs == [(leg.state, leg.last_cycle) for leg in python.scheduler.legs], tick
    active = native.references.contact_active
    assert np.array_equal(active, python.references.contact_active), tick
    (expected, tolerance), (actual, _) = flat_state(python), flat_state(native)
    if np.all(np.abs(actual - expected) <= tolerance):
        return
    for name, value in walking_state(python).items():  # name the first field that differs
        reference = np.asarray(value, dtype=float)
        np.testing.assert_allclose(
            np.asarray(walking_state(native)[name], dtype=float),
            reference,
            rtol=0,
            atol=TOL * (1.0 + np.abs(reference).max()),
            err_msg=f"{name} at tick {tick}",
        )


@pytest.mark.parametrize(
    ("gait", "footholds"),
    [("trot", "robocentric"), ("trot", "raibert"), ("crawl", "robocentric")],
)
def test_the_native_walking_tick_agrees_with_python(gait: str, footholds: str) -> None:
    """Three walkings given a recorded trot (lift-offs, touchdowns, a turn): one runs every tick
    in Python, one every tick natively, one alternates in blocks; a new step height mid-stride.
    Every state, posture and reference stays equal within 1e-9. The crawl, given the trot's
    touches and then none, reaches and gives up."""
    assert walking_module.NativeWalking is not None, "the kernel lacks Walking"
    robot, calls = recorded_trot()
    model = RobotModel(robot.model, robot.contacts)
    python, native, mixed = (Walking(model, robot.q_standing, GAITS[gait]) for _ in range(3))
    for walking in (python, native, mixed):
        walking.configure(footholds=footholds)
    events, reaching = 0, 0
    for tick, (t, q, v, command, touching) in enumerate(calls):
        if tick == CONFIGURE_AT:
            step_height = 0.8 * python.step_height
            for walking in (python, native, mixed):
                walking.configure(step_height=step_height)
        if gait == "crawl" and tick >= NUMB_FROM:
            touching = np.zeros_like(touching)  # the ground unfelt: a leg reaches, gives up
        model.update(q, v)
        states = [leg.state for leg in python.scheduler.legs] if python.scheduler else []
        python.update(t, model, command, touching)
        events += states != [leg.state for leg in python.scheduler.legs]
        reaching += any(leg.state is LegState.REACHING for leg in python.scheduler.legs)
        tick_native_and_mixed(tick, model, native, mixed, t, command, touching)
        assert_same_walking(native, python, tick)
        assert_same_walking(mixed, python, tick)
    assert events >= 4  # legs lifted off and landed
    if gait == "crawl":
        assert reaching > 0


def test_bad_walking_state_raises_a_clear_error() -> None:
    robot, calls = recorded_trot()
    model = RobotModel(robot.model, robot.contacts)
    walking = Walking(model, robot.q_standing, GAITS["trot"])
    t, q, v, command, touching = calls[0]
    model.update(q, v)
    model.filled_elsewhere()
    walking.liftoff = np.zeros((3, 3))
    with pytest.raises(ValueError, match="liftoff"):
        walking.update(t, model, command, touching)
    walking.liftoff = np.zeros((4, 3))
    walking.footholds = "psychic"
    with pytest.raises(ValueError, match="psychic"):
        walking.update(t, model, command, touching)


def test_a_native_trot_walks_at_the_commanded_velocity() -> None:
    """ANYmal trots at 0.5 m/s under Raiola S3 on the native kernel and walking tick: it does not
    fall and its base moves forward at the commanded velocity within 30 %."""
    session = Session(SessionConfig(robot="anymal"))
    session.handle("gait", {"name": "trot"})
    session.handle("velocity", {"vx": 0.5})
    for _ in range(1500):
        session.tick()
    start, t0 = session.model.base_position.copy(), session.time
    for _ in range(1500):
        session.tick()
    assert session.controller.kernel_ran == "native"
    assert session.model.updated_by == "native"
    assert not session.behaviour._native_stale  # the native walking tick ran
    assert not session.fell and session.qp_failures == 0
    velocity = (session.model.base_position - start) / (session.time - t0)
    assert velocity[0] == pytest.approx(0.5, rel=0.3)
    assert abs(velocity[1]) < 0.1


def scripted_touching(walking: Walking, t: float) -> np.ndarray:
    """Which feet touch at `t` in the scripted walk: those in stance, and a swinging foot once
    its swing has run its leg's TOUCHDOWN_AT fraction of the planned swing."""
    if walking.scheduler is None:
        return np.ones(4, dtype=bool)
    return np.array(
        [
            leg.state is LegState.STANCE or t - leg.since >= late * leg.swing_duration
            for leg, late in zip(walking.scheduler.legs, TOUCHDOWN_AT, strict=True)
        ]
    )


@pytest.mark.parametrize("gait", list(GAITS))
@pytest.mark.parametrize("robot_name", WALKERS)
def test_every_gait_of_every_walker_agrees_with_python(robot_name: str, gait: str) -> None:
    """Every gait on every four-footed robot (not only ANYmal's recorded trot): three walkings
    given the same scripted state (walking forward, turning, wobbling) and touchdowns early, on
    time and late, steered, then given a new step height and cycle time mid-stride. Every
    state, posture and reference stays equal within 1e-9; every leg lifts off and lands."""
    robot = build_robot(load_description(robot_name))
    model = RobotModel(robot.model, robot.contacts)
    model.update(*scripted_state(robot.q_standing, 0.0))
    python, native, mixed = (Walking(model, robot.q_standing, GAITS[gait]) for _ in range(3))
    command = np.array([0.3, 0.05, 0.2])
    touchdowns = np.zeros(4, dtype=int)
    new_options = {"step_height": 0.8 * python.step_height, "cycle_time": 0.9 * python.cycle_time}
    ticks = round(3.0 * python.cycle_time / SCRIPTED_DT)
    for tick in range(ticks):
        t = 1.0 + tick * SCRIPTED_DT
        if tick == ticks // 2:
            for walking in (python, native, mixed):
                walking.configure(**new_options)
        touching = scripted_touching(python, t)
        model.update(*scripted_state(robot.q_standing, t, speed=0.2))
        before = [leg.state for leg in python.scheduler.legs] if python.scheduler else []
        python.update(t, model, command, touching)
        after = [leg.state for leg in python.scheduler.legs]
        touchdowns += [
            b is not LegState.STANCE and a is LegState.STANCE
            for b, a in zip(before or after, after, strict=True)
        ]
        tick_native_and_mixed(tick, model, native, mixed, t, command, touching)
        assert_same_walking(native, python, tick)
        assert_same_walking(mixed, python, tick)
    assert touchdowns.min() >= 2, touchdowns
